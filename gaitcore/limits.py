"""Ceilings on what gaitcore reads, set before any library can allocate for it."""

MAX_IMAGE_PIXELS = 100_000_000
"""The most pixels an image file may decode to (an 8K frame has 33 million): a small file
that claims more (an image bomb) is refused before OpenCV allocates it."""
