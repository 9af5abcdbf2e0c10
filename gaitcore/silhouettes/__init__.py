"""Stage 2, silhouettes (paper 2.2): rectangles and strokes, colour models, segmentation,
sketches, subject tracking and region-of-interest crops."""
