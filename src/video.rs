//! Frame sources: streaming video decode.
