"""Written answers: questions a lab asks in prose, graded by hand against the rubric in its instructor notes.

A lab's suite declares them (`written("09.gap_report", "Sim-to-real report", points=6)`); the notebook has
a markdown cell tagged `answer` whose metadata names the question. `pendkit grade` collects each answer's
text into results.json and leaves a column for it in grades.csv; no point is given automatically.
"""

from __future__ import annotations

from dataclasses import dataclass

ANSWER_PROMPT = "*Write your answer here (double-click this cell).*"
MAX_ANSWER_CHARS = 5000


@dataclass(frozen=True)
class WrittenQuestion:
    id: str
    title: str
    points: float


@dataclass(frozen=True)
class WrittenAnswer:
    question: WrittenQuestion
    text: str  # "" when the student wrote nothing


QUESTIONS: dict[str, WrittenQuestion] = {}


def written(question_id: str, title: str, points: float) -> WrittenQuestion:
    """Declare a question graded by hand ("NN.name", NN the lab)."""
    QUESTIONS[question_id] = WrittenQuestion(question_id, title, points)
    return QUESTIONS[question_id]


def questions_of(lab: str) -> list[WrittenQuestion]:
    return [q for q in QUESTIONS.values() if q.id.split(".", 1)[0] == lab]


def collect_answers(notebook, lab: str) -> list[WrittenAnswer]:
    """Each declared question's answer: the text of the markdown cells tagged for it (the prompt alone,
    or no cell, is no answer)."""
    answers = []
    for question in questions_of(lab):
        texts = [str(cell.get("source", "")) for cell in notebook.get("cells", [])
                 if cell.get("cell_type") == "markdown"
                 and (cell.get("metadata", {}).get("pendkit") or {}).get("answer") == question.id]
        text = "\n\n".join(t.strip() for t in texts if t.strip() and t.strip() != ANSWER_PROMPT)
        answers.append(WrittenAnswer(question, text[:MAX_ANSWER_CHARS]))
    return answers
