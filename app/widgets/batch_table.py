"""The summary of a ``gaitcore batch`` run as a sortable table, to pick a clip to open.

Rows come sorted usable first, then by r (the weaker of r1 and r2) from best to worst;
clicking a header sorts by that column. Double-clicking a row (or Open clip) emits
:attr:`BatchTableDialog.clipChosen` with the clip's project file, which the batch wrote with
the footage, its trim, the rectangles and the tracked silhouettes.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QSortFilterProxyModel, Qt, Signal
from PySide6.QtGui import QStandardItem, QStandardItemModel
from PySide6.QtWidgets import (
    QAbstractItemView,
    QDialog,
    QDialogButtonBox,
    QHeaderView,
    QLabel,
    QTableView,
    QVBoxLayout,
    QWidget,
)

from gaitcore.project.batch import ClipSummary

COLUMNS = ("Clip", "Verdict", "Period", "r1", "r2", "Frames", "Cycle", "Error")
SORT_ROLE = Qt.ItemDataRole.UserRole + 1


def ranked(rows: tuple[ClipSummary, ...]) -> list[ClipSummary]:
    """Usable clips first, then analysed ones, then the rest; each by r, best first."""
    def key(row: ClipSummary):
        return (not row.usable, row.status != "done", -row.score, row.clip)
    return sorted(rows, key=key)


def _cells(row: ClipSummary) -> list[tuple[str, object]]:
    """(text, sort key) of each column."""
    def num(v, fmt):
        return ("" if v is None else format(v, fmt)), (float("-inf") if v is None else v)
    verdict = row.verdict if row.status == "done" else row.status
    cycle = "" if row.cycle_start is None else f"{row.cycle_start}-{row.cycle_stop}"
    return [(row.clip, row.clip), (verdict, (not row.usable, row.status != "done", verdict)),
            num(row.period_frames, ".1f"), num(row.r1, ".2f"), num(row.r2, ".2f"),
            num(row.frames, "d"), (cycle, row.cycle_start if row.cycle_start is not None else -1),
            (row.error, row.error)]


class BatchTableDialog(QDialog):
    """A batch summary to browse; not modal, so the window stays usable beside it.

    Signals
    -------
    clipChosen(object)
        The :class:`~pathlib.Path` of the chosen clip's project file.
    messageRaised(str)
        Why a row cannot be opened (not analysed yet, a bad manifest row).
    """

    clipChosen = Signal(object)
    messageRaised = Signal(str)

    def __init__(self, rows: tuple[ClipSummary, ...], summary_path: Path,
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle(f"Batch summary: {summary_path}")
        self._out_dir = Path(summary_path).parent
        self._rows = ranked(rows)
        model = QStandardItemModel(len(self._rows), len(COLUMNS), self)
        model.setHorizontalHeaderLabels(list(COLUMNS))
        for r, row in enumerate(self._rows):
            for c, (text, key) in enumerate(_cells(row)):
                item = QStandardItem(text)
                item.setData(key, SORT_ROLE)
                item.setData(r, Qt.ItemDataRole.UserRole)
                item.setEditable(False)
                item.setToolTip(text)
                model.setItem(r, c, item)
        self._proxy = QSortFilterProxyModel(self)
        self._proxy.setSourceModel(model)
        self._proxy.setSortRole(SORT_ROLE)
        self.table = QTableView()
        self.table.setModel(self._proxy)
        self.table.setSortingEnabled(True)
        self.table.sortByColumn(-1, Qt.SortOrder.AscendingOrder)  # keep the ranked order
        self.table.verticalHeader().hide()
        self.table.setWordWrap(False)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.doubleClicked.connect(lambda index: self.open_row(index.row()))
        usable = sum(bool(r.usable) for r in self._rows)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Close)
        open_button = buttons.addButton("Open clip", QDialogButtonBox.ButtonRole.ActionRole)
        open_button.clicked.connect(self._open_selected)
        buttons.rejected.connect(self.close)
        layout = QVBoxLayout(self)
        layout.addWidget(QLabel(f"{len(self._rows)} clips, {usable} usable. Double-click a clip "
                                "to open it with its box and trim."))
        layout.addWidget(self.table)
        layout.addWidget(buttons)
        self.resize(820, 420)

    def row_at(self, view_row: int) -> ClipSummary:
        """The clip shown on row ``view_row`` of the table (after sorting)."""
        return self._rows[self._proxy.index(view_row, 0).data(Qt.ItemDataRole.UserRole)]

    def open_row(self, view_row: int) -> None:
        """Emit the project of the clip on ``view_row``, or say why it has none."""
        row = self.row_at(view_row)
        path = row.project_path(self._out_dir)
        if path is None:
            why = (row.error if row.status == "bad row"
                   else "it has not been analysed yet: run the batch again")
            self.messageRaised.emit(f"cannot open {row.clip}: {why}")
            return
        self.clipChosen.emit(path)

    def _open_selected(self) -> None:
        selected = self.table.selectionModel().selectedRows()
        if selected:
            self.open_row(selected[0].row())
