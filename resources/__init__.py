"""Data files shipped with gaitcore (installed as ``gaitcore.resources``): skeleton templates."""
