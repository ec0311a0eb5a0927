//! A plot's PDF: its SVG converted by `svg2pdf` (vector paths, text embedded as text
//! with a subset of the font), the page sized so the plot fills one paper column
//! ([`super::PLOT_SIZE`] at [`PDF_DPI`]).
//!
//! Fonts come from the system (fontconfig), read once per process; the SVG's
//! `sans-serif` is DejaVu Sans when it is installed (Debian: fonts-dejavu-core), else
//! the system's sans-serif. Without any sans-serif font the text would silently vanish
//! from the PDF, so that is an error instead.

use std::sync::{Arc, OnceLock};

use svg2pdf::usvg::{self, fontdb};

/// Plot units per inch of the PDF page: [`super::PLOT_SIZE`] (1008 x 748 units) makes a
/// 3.5 x 2.6 in page, one column of a two-column paper, 4 units to the point.
pub const PDF_DPI: f32 = 288.0;

/// The family the plots' `sans-serif` text is set in, when installed.
pub const PLOT_FONT: &str = "DejaVu Sans";

/// What to install when no sans-serif font is found.
const FONT_HINT: &str = "install a sans-serif font (Debian: apt-get install fonts-dejavu-core)";

/// The system's fonts, `sans-serif` mapped to [`PLOT_FONT`] when it is there; `None`
/// when no font answers `sans-serif`.
fn fonts() -> Option<Arc<fontdb::Database>> {
    static FONTS: OnceLock<Option<Arc<fontdb::Database>>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut db = fontdb::Database::new();
            db.load_system_fonts();
            if db
                .faces()
                .any(|f| f.families.iter().any(|(name, _)| name == PLOT_FONT))
            {
                db.set_sans_serif_family(PLOT_FONT);
            }
            let query = fontdb::Query {
                families: &[fontdb::Family::SansSerif],
                ..Default::default()
            };
            db.query(&query).map(|_| Arc::new(db))
        })
        .clone()
}

/// The PDF of a plot's SVG `text`, or why it could not be made.
pub fn pdf_from_svg(text: &str) -> Result<Vec<u8>, String> {
    let fontdb = fonts().ok_or_else(|| format!("no sans-serif font for the PDF: {FONT_HINT}"))?;
    let options = usvg::Options {
        fontdb,
        ..Default::default()
    };
    let tree = usvg::Tree::from_str(text, &options).map_err(|e| e.to_string())?;
    svg2pdf::to_pdf(
        &tree,
        svg2pdf::ConversionOptions::default(),
        svg2pdf::PageOptions { dpi: PDF_DPI },
    )
    .map(sorted_references)
    .map_err(|e| e.to_string())
}

/// `pdf` with each run of dictionary entries that are references (`  /xo3 14 0 R`, one
/// a line, as pdf-writer writes resources) in byte order. svg2pdf lists a page's
/// resources from a hash map, in an order that changes from run to run; sorted, a rerun
/// writes the same bytes (an unchanged session reruns to identical files). The runs only
/// change places within themselves, so every object keeps its offset; stream data is
/// left alone.
fn sorted_references(pdf: Vec<u8>) -> Vec<u8> {
    let is_reference = |l: &[u8]| {
        let t = l.trim_ascii_start();
        t.len() < l.len()
            && t.starts_with(b"/")
            && t.ends_with(b" 0 R")
            && t.iter().filter(|&&c| c == b' ').count() == 3
    };
    let mut out = Vec::with_capacity(pdf.len());
    let mut run: Vec<&[u8]> = Vec::new();
    let mut in_stream = false;
    for line in pdf.split_inclusive(|&c| c == b'\n') {
        let body = line.strip_suffix(b"\n").unwrap_or(line);
        if !in_stream && line.ends_with(b"\n") && is_reference(body) {
            run.push(line);
            continue;
        }
        run.sort_unstable();
        out.extend(run.drain(..).flatten());
        if in_stream {
            in_stream = !body.starts_with(b"endstream");
        } else {
            in_stream = body.ends_with(b"stream") && !body.ends_with(b"endstream");
        }
        out.extend_from_slice(line);
    }
    run.sort_unstable();
    out.extend(run.drain(..).flatten());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// References are sorted within their run, nothing else moves, stream data stays.
    #[test]
    fn reference_runs_are_sorted_in_place() {
        let pdf = b"<<\n  /xo6 20 0 R\n  /xo10 8 0 R\n  /xo3 14 0 R\n>>\nstream\n  /b 2 0 R\n  /a 1 0 R\nendstream\n  /f1 3 0 R\n".to_vec();
        let sorted = sorted_references(pdf.clone());
        assert_eq!(sorted.len(), pdf.len());
        assert_eq!(
            String::from_utf8(sorted).unwrap(),
            "<<\n  /xo10 8 0 R\n  /xo3 14 0 R\n  /xo6 20 0 R\n>>\nstream\n  /b 2 0 R\n  /a 1 0 R\nendstream\n  /f1 3 0 R\n"
        );
    }
}
