//! `bendscope inspect`: a frame with the session's marker thresholds as a page with
//! sliders (see `bendscope::inspect`).

use std::path::PathBuf;

use anyhow::Result;
use bendscope::inspect::{detect_block, inspect_frame, inspect_html, load_frame};
use bendscope::io::write_atomic;
use clap::Args;

use super::EXIT_OK;

/// Show a frame's marker mask with the session's thresholds in a page whose sliders
/// recompute it (inspect.html), and suggest a `[detect]` setting read from the frame.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// A session folder (its first video or photo), a video or an image.
    #[arg(value_name = "SESSION|VIDEO|IMAGE")]
    pub input: PathBuf,
    /// Frame number of a video (0 = the first).
    #[arg(long, default_value_t = 0, value_parser = frame_number, allow_hyphen_values = true)]
    pub frame: u64,
    /// Settings (default: the session's or the file's folder's bendscope.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The page to write.
    #[arg(short, long, value_name = "FILE", default_value = "inspect.html")]
    pub output: PathBuf,
}

/// `--frame` as a frame number, with a message that says what one is.
fn frame_number(s: &str) -> Result<u64, String> {
    s.trim()
        .parse::<u64>()
        .map_err(|_| format!("`{s}` is not a frame number: give 0 (the first frame) or more"))
}

/// Runs `bendscope inspect`.
pub fn run(args: &InspectArgs) -> Result<u8> {
    if args.output.is_dir() {
        anyhow::bail!(
            "{} is a folder: give the page's file name, e.g. -o {}",
            args.output.display(),
            args.output.join("inspect.html").display()
        );
    }
    super::check_output_file(&args.output)?;
    let (frame, source, config) = load_frame(&args.input, args.frame, args.config.as_deref())?;
    let i = inspect_frame(&frame, source, &config.detect);
    write_atomic(&args.output, inspect_html(&i)?.as_bytes())?;
    out!(
        "{}: {} mask px, {} blobs with the session's settings; wrote {}",
        i.source,
        i.mask_px,
        i.blobs.len(),
        args.output.display()
    );
    match &i.suggested {
        Some(s) => out!(
            "suggested from {} marker-like blobs of one colour:\n{}",
            s.blobs,
            detect_block(&s.band).trim_end()
        ),
        None => out!("no group of 3 or more marker-like coloured blobs in this frame"),
    }
    Ok(EXIT_OK)
}
