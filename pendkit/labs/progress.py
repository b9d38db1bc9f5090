"""Labs 05 and 06: tqdm's auto bar, whose saved notebook output ends at the bar's final count.

In a notebook tqdm.auto draws a widget, and the notebook file keeps the widget's text as it was first shown
("0/20"): all a run without a browser (nbconvert, the grader) saves. This bar shows itself under a display id
and re-shows its text when it closes, so the saved file says how far it got."""

from __future__ import annotations

import functools


def progress(iterable=None, **options):
    """A tqdm.auto bar over `iterable` (or with `total=`), its closing state saved in the notebook."""
    from tqdm.auto import tqdm
    from tqdm.notebook import tqdm as notebook_bar

    if not issubclass(tqdm, notebook_bar):  # a terminal: tqdm's text bar already ends at its count
        return tqdm(iterable, **options)
    return _saved_bar_class()(iterable, **options)


@functools.cache
def _saved_bar_class():  # built when first needed: tqdm.notebook needs ipywidgets, which only the labs install
    from IPython.display import display
    from tqdm.notebook import tqdm as notebook_bar

    class SavedBar(notebook_bar):
        def __init__(self, iterable=None, **options):
            super().__init__(iterable, display=False, **options)
            self._handle = display(self.container, display_id=True)
            self.displayed = True

        def close(self):
            super().close()
            if getattr(self, "_handle", None) is not None:
                self._handle.update(self.container)  # the saved text/plain: the final count, not 0/N
                self._handle = None

    return SavedBar

