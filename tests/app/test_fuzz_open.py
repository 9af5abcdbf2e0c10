"""The window opening fuzzed projects and batch summaries: the project opens, or one dialog
of one line says why; nothing escapes (issue #64).

The cases are those of the readers' fuzz tests (:mod:`tests.gaitcore.test_fuzz_readers`),
run in the process: a Qt window cannot be forked.
"""

from __future__ import annotations

from pathlib import Path

from tests.app.conftest import wait_jobs
from tests.fuzzing import CASE_COUNTS, fuzz, json_cases
from tests.gaitcore.test_fuzz_readers import _summary_doc, project_cases, valid_project

__all__ = ["valid_project"]  # the fixture, shared with the readers' fuzz test


def _opens_or_says_why(qtbot, window, asker, open_it):
    def read(path: Path) -> None:
        asker.errors.clear()
        with qtbot.capture_exceptions() as raised:
            open_it(path)
            wait_jobs(qtbot, window)
        assert not raised, raised[0][1]
        assert len(asker.errors) <= 1 and all("\n" not in e for e in asker.errors), asker.errors
    return read


@CASE_COUNTS
def test_fuzzed_projects_open_or_say_why(qtbot, window, asker, valid_project, tmp_path, n_cases):
    fuzz(*project_cases(valid_project), _opens_or_says_why(qtbot, window, asker,
                                                           window.open_path),
         tmp_path, n_cases=n_cases, isolate=False)


@CASE_COUNTS
def test_fuzzed_batch_summaries_open_or_say_why(qtbot, window, asker, tmp_path, n_cases):
    doc = _summary_doc(tmp_path)

    def write(text: str, folder: Path) -> Path:
        (folder / "summary.json").write_text(text, encoding="utf-8", errors="surrogateescape")
        return folder / "summary.json"

    def open_summary(path: Path) -> None:
        table = window.open_batch_summary(path)
        if table is not None:
            table.close()

    fuzz(json_cases(doc), write, _opens_or_says_why(qtbot, window, asker, open_summary),
         tmp_path / "cases", n_cases=n_cases, isolate=False)
