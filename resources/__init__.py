"""Data files shipped with gaitcore (installed as ``gaitcore.resources``): skeleton templates
and the gait library of example poses."""
