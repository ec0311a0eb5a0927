//! Sessions: batches of videos with a pressure manifest, and their aggregation.
