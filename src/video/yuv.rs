//! Decoded 4:2:0 frames kept in YUV at their native depth (8- or 10-bit samples), read
//! in place from the decoder's buffers, converted to RGB pixel by pixel where asked.
//!
//! The BT.601 conversion is written here rather than left to swscale because detection
//! converts only the few pixels that may be markers (see `crate::detect`'s YUV pixel
//! source), never whole frames.

use std::sync::Arc;

use ffmpeg_next as ffmpeg;
use image::RgbImage;

mod sealed {
    /// Only the sample types below: [`super::YuvFrame`] reads decoder buffers as them.
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for u16 {}
}

/// A sample of a YUV plane: 8-bit, or 10-bit in 16 bits (HEVC Main 10, as recent
/// GoPros record). Conversions work at the sample's own depth. Sealed: implemented for
/// `u8` and `u16` only, types for which every bit pattern is a value.
pub trait Sample:
    sealed::Sealed + Copy + Default + Ord + Send + Sync + std::fmt::Debug + 'static
{
    /// Bits beyond 8 (0 for 8-bit samples, 2 for 10-bit ones).
    const EXTRA_BITS: u32;
    /// The sample's value.
    fn value(self) -> i32;
    /// The sample of value `v`, saturated to the type's range.
    fn saturated(v: i32) -> Self;
}

impl Sample for u8 {
    const EXTRA_BITS: u32 = 0;
    #[inline]
    fn value(self) -> i32 {
        self as i32
    }
    fn saturated(v: i32) -> Self {
        v.clamp(0, u8::MAX as i32) as u8
    }
}

impl Sample for u16 {
    const EXTRA_BITS: u32 = 2;
    #[inline]
    fn value(self) -> i32 {
        self as i32
    }
    fn saturated(v: i32) -> Self {
        v.clamp(0, u16::MAX as i32) as u16
    }
}

/// Where a [`YuvFrame`]'s samples live.
#[derive(Clone)]
enum Planes<T> {
    /// Y, Cb, Cr copied into vectors.
    Owned([Vec<T>; 3]),
    /// The decoder's own frame: its buffers are reference-counted and go back to
    /// FFmpeg's pool when the last holder drops it, so a 4K frame is never copied (a
    /// 10-bit 4K frame is 25 MB; copying it cost ~3% of the run and a buffer per frame
    /// in flight).
    Decoded(Arc<ffmpeg::frame::Video>),
}

/// A decoded 4:2:0 frame kept in YUV at its native depth: detection reads the
/// quarter-size Cr plane first and converts to RGB only the pixels that may be red,
/// instead of converting whole frames. BT.601, limited or full range. `T` is `u8` for
/// 8-bit streams, `u16` for 10-bit ones. The planes are the decoder's buffers (no copy)
/// or owned vectors ([`YuvFrame::from_planes`]).
#[derive(Clone)]
pub struct YuvFrame<T: Sample = u8> {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Full-range (JPEG) levels instead of limited (16..235).
    pub full_range: bool,
    planes: Planes<T>,
    /// Row strides of Y, Cb, Cr, samples.
    pub(crate) strides: [usize; 3],
}

impl<T: Sample> Default for YuvFrame<T> {
    fn default() -> Self {
        Self {
            width: 0,
            height: 0,
            full_range: false,
            planes: Planes::Owned([vec![], vec![], vec![]]),
            strides: [0; 3],
        }
    }
}

impl<T: Sample> std::fmt::Debug for YuvFrame<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("YuvFrame")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("full_range", &self.full_range)
            .field("zero_copy", &matches!(self.planes, Planes::Decoded(_)))
            .finish()
    }
}

impl<T: Sample> YuvFrame<T> {
    /// A frame from packed planes: `y` is `width` x `height`, `u` and `v` are
    /// ceil(width/2) x ceil(height/2); `None` when a plane is too short.
    pub fn from_planes(
        width: u32,
        height: u32,
        y: Vec<T>,
        u: Vec<T>,
        v: Vec<T>,
        full_range: bool,
    ) -> Option<Self> {
        let (w, h) = (width as usize, height as usize);
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        (y.len() >= w * h && u.len() >= cw * ch && v.len() >= cw * ch).then(|| Self {
            width,
            height,
            full_range,
            planes: Planes::Owned([y, u, v]),
            strides: [w, cw, cw],
        })
    }

    /// The decoder's frame itself when its three planes can be read as `T` samples in
    /// place (aligned, whole-sample strides, little-endian for 16-bit samples), else
    /// `None`.
    pub(super) fn from_decoded(frame: ffmpeg::frame::Video, full_range: bool) -> Option<Self> {
        let bytes = std::mem::size_of::<T>();
        if frame.planes() < 3 || (bytes > 1 && cfg!(target_endian = "big")) {
            return None;
        }
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        let mut strides = [0; 3];
        for (i, (row, rows)) in [(w, h), (cw, ch), (cw, ch)].into_iter().enumerate() {
            let data = frame.data(i);
            let stride = frame.stride(i);
            let aligned = (data.as_ptr() as usize).is_multiple_of(std::mem::align_of::<T>());
            if !aligned || !stride.is_multiple_of(bytes) || stride < row * bytes {
                return None;
            }
            if data.len() < (rows.max(1) - 1) * stride + row * bytes {
                return None;
            }
            strides[i] = stride / bytes;
        }
        Some(Self {
            width: frame.width(),
            height: frame.height(),
            full_range,
            planes: Planes::Decoded(Arc::new(frame)),
            strides,
        })
    }

    /// Plane `i` (0 Y, 1 Cb, 2 Cr) as samples, rows [`Self::strides`] apart.
    #[inline]
    pub(crate) fn plane(&self, i: usize) -> &[T] {
        match &self.planes {
            Planes::Owned(p) => &p[i],
            Planes::Decoded(f) => {
                let data = f.data(i);
                // SAFETY: `T` is u8 or u16 (Sample is sealed), for which every bit
                // pattern is a valid value; `from_decoded` checked that the plane is
                // aligned for `T`; the length stays within `data`.
                unsafe {
                    std::slice::from_raw_parts(
                        data.as_ptr() as *const T,
                        data.len() / std::mem::size_of::<T>(),
                    )
                }
            }
        }
    }

    /// RGB at (x, y): BT.601, chroma of the 2x2 block the pixel belongs to; integer
    /// arithmetic at the samples' depth, rounded once to 8 bits.
    #[inline]
    pub fn rgb_at(&self, x: u32, y: u32) -> [u8; 3] {
        let (cy, cx) = (y as usize / 2, x as usize / 2);
        self.rgb_of(
            self.plane(0)[y as usize * self.strides[0] + x as usize],
            self.plane(1)[cy * self.strides[1] + cx],
            self.plane(2)[cy * self.strides[2] + cx],
        )
    }

    /// RGB of one luma and its chroma samples (the conversion of [`Self::rgb_at`], for
    /// callers that hold the planes' rows: a plane lookup asks FFmpeg for the pixel
    /// format's descriptor).
    #[inline]
    pub(crate) fn rgb_of(&self, luma: T, cb: T, cr: T) -> [u8; 3] {
        let k = T::EXTRA_BITS;
        let yy = luma.value();
        let (d, e) = (cb.value() - (128 << k), cr.value() - (128 << k));
        let (r, g, b) = if self.full_range {
            let c = yy << 8;
            (c + 359 * e, c - 88 * d - 183 * e, c + 454 * d)
        } else {
            let c = 298 * (yy - (16 << k));
            (c + 409 * e, c - 100 * d - 208 * e, c + 516 * d)
        };
        let q = |v: i32| ((v + (128 << k)) >> (8 + k)).clamp(0, 255) as u8;
        [q(r), q(g), q(b)]
    }

    /// The whole frame in RGB (for overlays and full-frame undistortion).
    pub fn to_rgb(&self) -> RgbImage {
        RgbImage::from_fn(self.width, self.height, |x, y| {
            image::Rgb(self.rgb_at(x, y))
        })
    }
}
