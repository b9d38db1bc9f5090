"""What a student sees in the notebook around the checks: one note per missing function, no stray output."""

from pendkit.grading import attempt, check


def test_a_missing_function_is_noted_once_however_often_a_cell_calls_it(capsys):
    def wrap_delta(new, old):
        raise NotImplementedError

    assert [attempt(wrap_delta, k, 0) for k in range(120)] == [None] * 120
    assert capsys.readouterr().out.count("wrap_delta is not implemented yet") == 1

    def wrap_delta(new, old):  # noqa: F811 - the student runs the cell again, still a stub
        raise NotImplementedError

    attempt(wrap_delta, 1, 0)
    assert capsys.readouterr().out.count("not implemented yet") == 1


def test_a_check_cell_shows_its_table_and_no_out_line(capsys):
    score = check("01.wrap_delta", lambda new, old: new - old)
    assert "01.wrap_delta" in capsys.readouterr().out
    assert score == 2 and hasattr(score, "_ipython_display_") and score._ipython_display_() is None
