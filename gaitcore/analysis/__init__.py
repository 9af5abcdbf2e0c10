"""Stage 3, analysis (paper 2.3, 3.1, 3.2, 5.2): image PCA, spectral diagnosis, key-image
selection, alternates, and the analysis of a clip with its settings."""
