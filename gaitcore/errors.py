"""Errors raised by gaitcore for bad input.

Every message says what is wrong and what to do about it; the command line prints it on one
line and exits with status 2, the GUI shows it in a dialog.
"""

from __future__ import annotations


class GaitInputError(ValueError):
    """Input that gaitcore cannot work with (bad files, too few frames, singular systems...)."""
