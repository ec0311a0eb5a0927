//! What a measurement produces, below every module that makes or reads one: the
//! records of frames and videos with their typed statuses ([`records`]) and their
//! statistics ([`stats`]). [`crate::pipeline`] fills them (and re-exports both modules
//! under its own name), [`crate::rgbd`] rejects frames with their statuses, and
//! [`crate::report`] never sees them (its page has rows of its own).

pub mod records;
pub mod stats;
