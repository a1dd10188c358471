"""The undo-to-the-start / redo-to-the-end check every document's tests share (issue 21)."""


def undo_all_redo_all(doc, start: bytes, end: bytes) -> int:
    """Undo to the start (``start`` bytes), redo to the end (``end`` bytes), within the history's byte budget;
    returns the number of undo steps."""
    steps = 0
    while doc.can_undo:
        doc.undo()
        steps += 1
    assert doc.state_bytes() == start
    while doc.can_redo:
        doc.redo()
    assert doc.state_bytes() == end
    assert doc.history.nbytes <= doc.history.max_bytes
    return steps
