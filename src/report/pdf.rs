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
    .map_err(|e| e.to_string())
}
