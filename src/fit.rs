//! Fits on marker centroids: circles (Pratt), bending angle, power-law curves.
