//! Reports: CSV tables, plots and QA overlays.
