//! The ROS1 messages of a RealSense recording, decoded by hand from their serialization.
//!
//! ROS1 serializes a message as its fields in definition order, little-endian, with no
//! padding: `uint32`/`float64` as 4/8 bytes, `time` as `uint32 sec, uint32 nsec`, a
//! `string` or variable array as a `uint32` count then the elements, a fixed array
//! (`float64[9]`) as its elements only, a nested message inline. The definitions
//! (as the bag's connection records carry them, `message_definition`):
//!
//! ```text
//! std_msgs/Header          uint32 seq, time stamp, string frame_id
//! sensor_msgs/Image        Header header, uint32 height, uint32 width, string encoding,
//!                          uint8 is_bigendian, uint32 step, uint8[] data
//! sensor_msgs/CameraInfo   Header header, uint32 height, uint32 width,
//!                          string distortion_model, float64[] D, float64[9] K,
//!                          float64[9] R, float64[12] P, uint32 binning_x,
//!                          uint32 binning_y, RegionOfInterest roi (uint32 x4, bool)
//! std_msgs/Float32         float32 data
//! geometry_msgs/Transform  Vector3 translation (float64 x y z),
//!                          Quaternion rotation (float64 x y z w)
//! ```

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Why a message could not be decoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MsgError {
    /// The bytes end before the field.
    #[error("message ends at byte {at} inside field `{field}` (needs {need} more bytes)")]
    Short {
        /// The field being read.
        field: &'static str,
        /// Offset where it starts.
        at: usize,
        /// Bytes it needs past the end.
        need: usize,
    },
    /// A field has a value the message cannot have.
    #[error("field `{field}`: {why}")]
    Invalid {
        /// The field.
        field: &'static str,
        /// What is wrong.
        why: String,
    },
}

/// Reads ROS1-serialized fields in order.
struct Fields<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Fields<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }

    fn take(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], MsgError> {
        let left = self.bytes.len() - self.at;
        if n > left {
            return Err(MsgError::Short {
                field,
                at: self.at,
                need: n - left,
            });
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn u8(&mut self, field: &'static str) -> Result<u8, MsgError> {
        Ok(self.take(1, field)?[0])
    }

    fn u32(&mut self, field: &'static str) -> Result<u32, MsgError> {
        let b = self.take(4, field)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn f32(&mut self, field: &'static str) -> Result<f32, MsgError> {
        Ok(f32::from_bits(self.u32(field)?))
    }

    fn f64(&mut self, field: &'static str) -> Result<f64, MsgError> {
        let b = self.take(8, field)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(f64::from_le_bytes(a))
    }

    fn bytes(&mut self, field: &'static str) -> Result<&'a [u8], MsgError> {
        let n = self.u32(field)? as usize;
        self.take(n, field)
    }

    fn string(&mut self, field: &'static str) -> Result<String, MsgError> {
        let b = self.bytes(field)?;
        std::str::from_utf8(b)
            .map(str::to_string)
            .map_err(|_| MsgError::Invalid {
                field,
                why: "not UTF-8".into(),
            })
    }

    fn f64s(&mut self, n: usize, field: &'static str) -> Result<Vec<f64>, MsgError> {
        (0..n).map(|_| self.f64(field)).collect()
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Sequence number (RealSense: the camera's frame number).
    pub seq: u32,
    /// Stamp, ns (RealSense: the frame timestamp).
    pub stamp_ns: u64,
    /// Coordinate frame name.
    pub frame_id: String,
}

fn header(f: &mut Fields<'_>) -> Result<Header, MsgError> {
    let seq = f.u32("header.seq")?;
    let sec = f.u32("header.stamp.sec")?;
    let nsec = f.u32("header.stamp.nsec")?;
    let frame_id = f.string("header.frame_id")?;
    Ok(Header {
        seq,
        stamp_ns: sec as u64 * 1_000_000_000 + nsec as u64,
        frame_id,
    })
}

/// `sensor_msgs/Image`, pixels borrowed from the message bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageMsg<'a> {
    /// Header.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`rgb8`, `bgr8`, `rgba8`, `bgra8`, `16UC1`, `mono16`, ...).
    pub encoding: String,
    /// Multi-byte samples are big-endian.
    pub is_bigendian: bool,
    /// Bytes per row.
    pub step: u32,
    /// Pixels, `step * height` bytes.
    pub data: &'a [u8],
}

/// Decodes a `sensor_msgs/Image`, checking that `data` holds `step * height` bytes.
pub fn image_from_bytes(bytes: &[u8]) -> Result<ImageMsg<'_>, MsgError> {
    let mut f = Fields::new(bytes);
    let header = header(&mut f)?;
    let height = f.u32("height")?;
    let width = f.u32("width")?;
    let encoding = f.string("encoding")?;
    let is_bigendian = f.u8("is_bigendian")? != 0;
    let step = f.u32("step")?;
    let data = f.bytes("data")?;
    if (data.len() as u64) < step as u64 * height as u64 {
        return Err(MsgError::Invalid {
            field: "data",
            why: format!("{} bytes for {height} rows of {step} bytes", data.len()),
        });
    }
    Ok(ImageMsg {
        header,
        height,
        width,
        encoding,
        is_bigendian,
        step,
        data,
    })
}

/// The header of a `sensor_msgs/Image` only (no pixels touched): to time frames.
pub fn image_header_from_bytes(bytes: &[u8]) -> Result<Header, MsgError> {
    header(&mut Fields::new(bytes))
}

/// `sensor_msgs/CameraInfo`: what a pinhole camera needs of it.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraInfoMsg {
    /// Header.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Distortion model name (`plumb_bob`; RealSense writes its own names, e.g.
    /// `Brown Conrady`, `Inverse Brown Conrady`).
    pub distortion_model: String,
    /// Distortion coefficients.
    pub d: Vec<f64>,
    /// Camera matrix, row-major: fx 0 cx / 0 fy cy / 0 0 1.
    pub k: [f64; 9],
}

/// Decodes a `sensor_msgs/CameraInfo` (R, P, binning and ROI are read past, unused).
pub fn camera_info_from_bytes(bytes: &[u8]) -> Result<CameraInfoMsg, MsgError> {
    let mut f = Fields::new(bytes);
    let header = header(&mut f)?;
    let height = f.u32("height")?;
    let width = f.u32("width")?;
    let distortion_model = f.string("distortion_model")?;
    let n = f.u32("D")? as usize;
    if n > 64 {
        return Err(MsgError::Invalid {
            field: "D",
            why: format!("{n} coefficients"),
        });
    }
    let d = f.f64s(n, "D")?;
    let mut k = [0.0; 9];
    k.copy_from_slice(&f.f64s(9, "K")?);
    f.f64s(9, "R")?;
    f.f64s(12, "P")?;
    Ok(CameraInfoMsg {
        header,
        height,
        width,
        distortion_model,
        d,
        k,
    })
}

/// Decodes a `std_msgs/Float32`.
pub fn float32_from_bytes(bytes: &[u8]) -> Result<f32, MsgError> {
    Fields::new(bytes).f32("data")
}

/// A rigid transform `p_to = rotation * p_from + translation_m` (librealsense's
/// `rs2_extrinsics`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidTransform {
    /// Rotation.
    pub rotation: Matrix3<f64>,
    /// Translation, m.
    pub translation_m: Vector3<f64>,
}

impl RigidTransform {
    /// No rotation, no translation.
    pub fn identity() -> Self {
        Self {
            rotation: Matrix3::identity(),
            translation_m: Vector3::zeros(),
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Self {
        let rt = self.rotation.transpose();
        Self {
            rotation: rt,
            translation_m: -(rt * self.translation_m),
        }
    }

    /// `self` after `first`: p -> self(first(p)).
    pub fn after(&self, first: &RigidTransform) -> Self {
        Self {
            rotation: self.rotation * first.rotation,
            translation_m: self.rotation * first.translation_m + self.translation_m,
        }
    }
}

/// Decodes a `geometry_msgs/Transform` (the quaternion is normalized; a zero one is
/// refused).
pub fn transform_from_bytes(bytes: &[u8]) -> Result<RigidTransform, MsgError> {
    let mut f = Fields::new(bytes);
    let t = f.f64s(3, "translation")?;
    let q = f.f64s(4, "rotation")?;
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let norm = (x * x + y * y + z * z + w * w).sqrt();
    if !(norm.is_finite() && norm > 1e-9) || !t.iter().all(|v| v.is_finite()) {
        return Err(MsgError::Invalid {
            field: "rotation",
            why: format!("not a rotation: quaternion ({x}, {y}, {z}, {w}), translation {t:?}"),
        });
    }
    let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
    Ok(RigidTransform {
        rotation: *q.to_rotation_matrix().matrix(),
        translation_m: Vector3::new(t[0], t[1], t[2]),
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// ROS1 serialization of test messages (the writer side of [`Fields`]).
    #[derive(Default)]
    pub(crate) struct Ser(pub Vec<u8>);

    impl Ser {
        pub fn u8(mut self, v: u8) -> Self {
            self.0.push(v);
            self
        }
        pub fn u32(mut self, v: u32) -> Self {
            self.0.extend_from_slice(&v.to_le_bytes());
            self
        }
        pub fn f64(mut self, v: f64) -> Self {
            self.0.extend_from_slice(&v.to_le_bytes());
            self
        }
        pub fn bytes(self, v: &[u8]) -> Self {
            let mut s = self.u32(v.len() as u32);
            s.0.extend_from_slice(v);
            s
        }
        pub fn header(self, seq: u32, sec: u32, nsec: u32, frame: &str) -> Self {
            self.u32(seq).u32(sec).u32(nsec).bytes(frame.as_bytes())
        }
    }

    #[test]
    fn image_decodes_every_field_and_refuses_short_data() {
        let px: Vec<u8> = (0..2 * 3 * 3).collect();
        let b = Ser::default()
            .header(41, 1700, 250_000_000, "cam")
            .u32(2)
            .u32(3)
            .bytes(b"rgb8")
            .u8(0)
            .u32(9)
            .bytes(&px)
            .0;
        let m = image_from_bytes(&b).unwrap();
        assert_eq!(m.header.seq, 41);
        assert_eq!(m.header.stamp_ns, 1_700_250_000_000);
        assert_eq!(m.header.frame_id, "cam");
        assert_eq!((m.height, m.width, m.step), (2, 3, 9));
        assert_eq!((m.encoding.as_str(), m.is_bigendian), ("rgb8", false));
        assert_eq!(m.data, &px[..]);
        assert_eq!(image_header_from_bytes(&b).unwrap(), m.header);
        // Cut inside the pixels: the length prefix says more than there is.
        assert!(matches!(
            image_from_bytes(&b[..b.len() - 1]),
            Err(MsgError::Short { field: "data", .. })
        ));
        // step * height larger than the data.
        let short = Ser::default()
            .header(0, 0, 0, "")
            .u32(2)
            .u32(3)
            .bytes(b"rgb8")
            .u8(0)
            .u32(10)
            .bytes(&px)
            .0;
        assert!(matches!(
            image_from_bytes(&short),
            Err(MsgError::Invalid { field: "data", .. })
        ));
    }

    #[test]
    fn camera_info_reads_k_and_d() {
        let k = [615.2, 0.0, 320.5, 0.0, 614.8, 241.25, 0.0, 0.0, 1.0];
        let mut s = Ser::default()
            .header(0, 3, 0, "color")
            .u32(480)
            .u32(640)
            .bytes(b"Brown Conrady")
            .u32(5);
        for d in [0.1, -0.2, 0.001, 0.002, 0.03] {
            s = s.f64(d);
        }
        for v in k.iter().chain(&[0.0; 9]).chain(&[0.0; 12]) {
            s = s.f64(*v);
        }
        let b = s.u32(0).u32(0).u32(0).u32(0).u32(0).u32(0).u8(0).0;
        let c = camera_info_from_bytes(&b).unwrap();
        assert_eq!((c.width, c.height), (640, 480));
        assert_eq!(c.distortion_model, "Brown Conrady");
        assert_eq!(c.d, vec![0.1, -0.2, 0.001, 0.002, 0.03]);
        assert_eq!(c.k, k);
        assert_eq!(c.header.stamp_ns, 3_000_000_000);
        // Cut inside K.
        let cut = 4 * 4 + 5 + 4 + 4 + 17 + 4 + 40 + 30;
        assert!(matches!(
            camera_info_from_bytes(&b[..cut]),
            Err(MsgError::Short { field: "K", .. })
        ));
    }

    #[test]
    fn float32_is_little_endian() {
        assert_eq!(float32_from_bytes(&0.001f32.to_le_bytes()), Ok(0.001f32));
        assert!(float32_from_bytes(&[0, 0]).is_err());
    }

    #[test]
    fn transform_rotates_as_its_quaternion() {
        // 90 degrees about z: x -> y; translation 15 mm along x.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let b = Ser::default()
            .f64(0.015)
            .f64(0.0)
            .f64(-0.001)
            .f64(0.0)
            .f64(0.0)
            .f64(h)
            .f64(h)
            .0;
        let t = transform_from_bytes(&b).unwrap();
        let p = t.rotation * Vector3::x() + t.translation_m;
        assert!((p - Vector3::new(0.015, 1.0, -0.001)).norm() < 1e-12, "{p}");
        let back = t.inverse().after(&t);
        assert!((back.rotation - Matrix3::identity()).norm() < 1e-12);
        assert!(back.translation_m.norm() < 1e-12);
        // A zero quaternion is no rotation.
        let zero = Ser::default()
            .f64(0.0)
            .f64(0.0)
            .f64(0.0)
            .f64(0.0)
            .f64(0.0)
            .f64(0.0)
            .f64(0.0)
            .0;
        assert!(transform_from_bytes(&zero).is_err());
        assert!(transform_from_bytes(&b[..40]).is_err());
    }
}
