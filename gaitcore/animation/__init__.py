"""Stage 4, animation (paper 2.4, 3.2): the RBF pose map, switching models, interpolation
weights, and the one function that animates from key poses."""
