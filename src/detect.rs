//! Marker detection: HSV red mask, hole fill, speck removal, connected components and
//! sub-pixel centroids.
