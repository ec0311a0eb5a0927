//! Key frames only (`[video] frames = "keyframes"`) on a short H.264 steady hold with a
//! known GOP: the decoder returns exactly the key frames, at their index and time in the
//! whole video, and the median radius over them matches the median over every frame.

use std::path::Path;

use bendscope::detect::{
    detect_markers_with, order_markers, ChainStart, ClampSide, DetectSettings, MaskBuffer,
};
use bendscope::fit::fit_circle_pratt;
use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
use bendscope::render::board::BoardPose;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::rng::SplitMix64;
use bendscope::video::{EncodeSettings, Pixels, VideoReader, VideoWriter};
use nalgebra::{Point2, Rotation3, Vector3};

const FPS: u32 = 30;
/// Frames from one key frame to the next: half a second at 30 fps, as action cameras
/// record.
const GOP: u32 = 15;
const FRAMES: u32 = 90;

/// A steady hold of the reference actuator (R 90 mm) through a GoPro-like fisheye at
/// 960x540, with sensor noise and a small tremble, H.264 with a key frame every [`GOP`].
fn write_hold(path: &Path) {
    let camera = gopro_like_camera(960, 540);
    let plane = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, 260.0),
    };
    let sampler = PlaneSampler::new(&camera, &plane, 1, 5).unwrap();
    let scene = ArcScene::reference_actuator(1.0 / 90.0, Point2::new(-50.0, 22.0));
    let look = FrameLook::default();
    let settings = EncodeSettings {
        fps: FPS,
        crf: 16,
        keyframe_interval: Some(GOP),
        ..Default::default()
    };
    let mut writer = VideoWriter::create(path, 960, 540, &settings).unwrap();
    let mut rng = SplitMix64::new(11);
    for f in 0..FRAMES {
        let shift = [0.05 * rng.normal(), 0.05 * rng.normal()];
        writer
            .write(&sampler.render(&scene, shift, &look, f as u64))
            .unwrap();
    }
    writer.finish().unwrap();
}

/// Index, time and fitted radius (px) of each frame the reader returns.
fn measure(reader: &mut VideoReader) -> Vec<(u64, f64, f64)> {
    let settings = DetectSettings::default();
    let mut buf = MaskBuffer::default();
    let mut out = Vec::new();
    while let Some((index, time_s, pixels)) = reader.next_pixels(1, None).unwrap() {
        let found = match &pixels {
            Pixels::Yuv(f) => detect_markers_with(f, &settings, &mut buf),
            Pixels::Yuv10(f) => detect_markers_with(f, &settings, &mut buf),
            Pixels::Rgb(i) => detect_markers_with(i, &settings, &mut buf),
        };
        let points: Vec<Point2<f64>> = found.blobs.iter().map(|b| b.centroid).collect();
        assert_eq!(points.len(), 8, "frame {index}: {} blobs", points.len());
        let ordered = order_markers(&points, ChainStart::Side(ClampSide::Left));
        out.push((index, time_s, fit_circle_pratt(&ordered).unwrap().radius));
    }
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[test]
fn key_frames_only_decodes_the_key_frames_and_keeps_the_median() {
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("GX010001.MP4");
    write_hold(&video);
    let mut all = VideoReader::open(&video).unwrap();
    let every = measure(&mut all);
    assert_eq!(every.len(), FRAMES as usize);
    let mut keys = VideoReader::open(&video).unwrap();
    keys.skip_non_key_frames();
    let key = measure(&mut keys);
    let indices: Vec<u64> = key.iter().map(|k| k.0).collect();
    let want: Vec<u64> = (0..FRAMES as u64).step_by(GOP as usize).collect();
    assert_eq!(indices, want, "the key frames, by index in the whole video");
    assert_eq!(keys.stats().frames_decoded, want.len() as u64);
    assert_eq!(keys.stats().packets_read, FRAMES as u64);
    assert!(!keys.stats().has_errors());
    for &(index, time_s, radius) in &key {
        // The same time, and the same picture, as that frame decoded with all the others.
        let (_, t, r) = every[index as usize];
        assert!(
            (time_s - t).abs() < 1e-6,
            "frame {index}: {time_s} s vs {t} s"
        );
        assert!(
            (radius / r - 1.0).abs() < 1e-9,
            "frame {index}: {radius} vs {r} px"
        );
    }
    let m_all = median(every.iter().map(|e| e.2).collect());
    let m_key = median(key.iter().map(|k| k.2).collect());
    let rel = (m_key / m_all - 1.0).abs();
    println!(
        "{} key frames of {FRAMES}: median radius {m_key:.4} px vs {m_all:.4} px ({:+.4}%)",
        key.len(),
        100.0 * (m_key / m_all - 1.0)
    );
    assert!(
        rel < 5e-4,
        "median radius {m_key} px over key frames vs {m_all} px over all: {:.3}%",
        100.0 * rel
    );
}
