//! `bendscope inspect` in a real browser: the page is loaded by headless Chromium (Debian's
//! package, installed by scripts/setup.sh), its mask is computed by the page's own script,
//! and a slider moved through the URL fragment changes it.

mod common;

use std::path::Path;
use std::process::Command;

use common::{fixture, Run};

/// The browser's DOM of `page` (with `fragment`) after its scripts ran.
fn dump_dom(page: &Path, fragment: &str, profile: &Path) -> String {
    let url = format!("file://{}{fragment}", page.display());
    let out = Command::new("chromium")
        .args([
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .expect("chromium runs (scripts/setup.sh installs Debian's chromium)");
    assert!(
        out.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The value of attribute `name` in `dom`.
fn attribute(dom: &str, name: &str) -> Option<u64> {
    let at = dom.find(&format!("{name}=\""))? + name.len() + 2;
    dom[at..].split('"').next()?.parse().ok()
}

#[test]
fn the_inspect_page_computes_the_mask_in_the_browser_and_its_sliders_change_it() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("inspect.html");
    let session = fixture("sessions/example");
    let run = Run::new(
        dir.path(),
        &[
            "inspect",
            session.to_str().unwrap(),
            "-o",
            page.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    // The example's red markers: eight blobs and a red band suggested from them.
    assert!(run.stdout.contains(", 8 blobs"), "{run}");
    assert!(
        run.stdout.contains("suggested from 8 marker-like blobs"),
        "{run}"
    );
    let dom = dump_dom(&page, "", &dir.path().join("profile"));
    assert!(
        dom.contains("data-ready=\"yes\""),
        "the page's script did not finish"
    );
    let rust = attribute(&dom, "data-rust-count").unwrap();
    let browser = attribute(&dom, "data-mask-count").unwrap();
    assert!(
        rust > 100,
        "the example's markers are in the mask: {rust} px"
    );
    // The page's port of the band test gives bendscope's mask on the same pixels.
    assert_eq!(browser, rust, "mask in the browser vs bendscope's");
    // A slider moved (v_min up to 250): the mask shrinks, and the block shows it.
    let moved = dump_dom(&page, "#v_min=250", &dir.path().join("profile2"));
    let after = attribute(&moved, "data-mask-count").unwrap();
    assert_eq!(attribute(&moved, "data-initial-mask-count"), Some(rust));
    assert!(after < rust / 2, "v_min 250 leaves {after} of {rust} px");
    assert!(
        moved.contains("v_min = 250"),
        "the [detect] block follows the slider"
    );
}

#[test]
fn inspect_refuses_what_it_cannot_read() {
    let dir = tempfile::tempdir().unwrap();
    Run::new(dir.path(), &["inspect", "no-such-session"])
        .assert_bad_input(&["no-such-session", "no such file or folder"]);
    let video = fixture("sessions/example/GX010101.MP4");
    let run = Run::new(
        dir.path(),
        &["inspect", video.to_str().unwrap(), "--frame", "100000"],
    );
    run.assert_bad_input(&["has no frame 100000", "--frame"]);
    assert!(!dir.path().join("inspect.html").exists());
    // A negative frame: what a frame number is, not the parser's words.
    let run = Run::new(
        dir.path(),
        &["inspect", video.to_str().unwrap(), "--frame", "-1"],
    );
    assert_eq!(run.code, 2, "{run}");
    assert!(
        run.stderr
            .contains("`-1` is not a frame number: give 0 (the first frame) or more"),
        "{run}"
    );
    assert!(!run.stderr.contains("invalid digit"), "{run}");
    // -o naming a folder: the folder is named.
    let out = dir.path().join("pages");
    std::fs::create_dir(&out).unwrap();
    Run::new(
        dir.path(),
        &[
            "inspect",
            video.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    )
    .assert_bad_input(&[out.to_str().unwrap(), "is a folder", "pages/inspect.html"]);
}

#[test]
fn inspect_reads_a_realsense_recording() {
    let dir = tempfile::tempdir().unwrap();
    let run = Run::new(
        dir.path(),
        &[
            "inspect",
            fixture("bags/baseline").to_str().unwrap(),
            "--frame",
            "2",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stdout.contains("recording.bag, frame 2"), "{run}");
    assert!(dir.path().join("inspect.html").is_file());
}
