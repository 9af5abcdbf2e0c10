"""Data files shipped with gaitcore (installed as ``gaitcore.resources``): skeleton templates, the gait library of example poses."""
