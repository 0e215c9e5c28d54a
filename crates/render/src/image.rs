//! Image buffers and their files: [`Channels`] (named `f32` channels, written and read as
//! OpenEXR with the `exr` crate) and [`Rgb8`] (8-bit RGB, written as PNG with the `png` crate).
//! Pixels are row-major, row 0 at the top.

use crate::error::RenderError;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// Named `f32` channels of one resolution (an EXR layer): raw counter values, radiance, …
#[derive(Clone, Debug, PartialEq)]
pub struct Channels {
    /// Pixels per row.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
    /// `(name, values)`, each `width · height` long, row-major.
    pub channels: Vec<(String, Vec<f32>)>,
}

impl Channels {
    /// An image without channels.
    pub fn new(width: u32, height: u32) -> Self {
        Channels {
            width,
            height,
            channels: Vec::new(),
        }
    }

    /// Add channel `name`; `values` must hold `width · height` samples.
    pub fn push(&mut self, name: &str, values: Vec<f32>) -> Result<(), RenderError> {
        if values.len() != self.width as usize * self.height as usize {
            return Err(RenderError::Mismatch(format!(
                "channel `{name}` has {} samples, the image {}x{}",
                values.len(),
                self.width,
                self.height
            )));
        }
        self.channels.push((name.to_string(), values));
        Ok(())
    }

    /// The values of channel `name`.
    pub fn get(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// The channel names.
    pub fn names(&self) -> Vec<&str> {
        self.channels.iter().map(|(n, _)| n.as_str()).collect()
    }

    /// Write as a single-layer OpenEXR file, every channel as 32-bit float, ZIP-compressed
    /// (lossless), so counts up to 2^24 are exact.
    pub fn write_exr(&self, path: &Path) -> Result<(), RenderError> {
        use exr::prelude::*;
        if self.channels.is_empty() {
            return Err(RenderError::Mismatch(format!(
                "{}: an image without channels",
                path.display()
            )));
        }
        let list: Vec<AnyChannel<FlatSamples>> = self
            .channels
            .iter()
            .map(|(n, v)| AnyChannel::new(n.as_str(), FlatSamples::F32(v.clone())))
            .collect();
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            LayerAttributes::default(),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(list)),
        );
        Image::from_layer(layer)
            .write()
            .to_file(path)
            .map_err(|e| RenderError::file(path, e))
    }

    /// Read the first layer of an OpenEXR file, every channel converted to `f32`.
    pub fn read_exr(path: &Path) -> Result<Self, RenderError> {
        let img = exr::prelude::read_first_flat_layer_from_file(path)
            .map_err(|e| RenderError::file(path, e))?;
        let layer = &img.layer_data;
        let size = layer.size;
        let mut out = Channels::new(size.0 as u32, size.1 as u32);
        for c in &layer.channel_data.list {
            let v: Vec<f32> = c.sample_data.values_as_f32().collect();
            out.push(&c.name.to_string(), v)?;
        }
        Ok(out)
    }
}

/// An 8-bit RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb8 {
    /// Pixels per row.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
    /// `3 · width · height` bytes, row-major.
    pub data: Vec<u8>,
}

impl Rgb8 {
    /// An image filled with `colour`.
    pub fn filled(width: u32, height: u32, colour: [u8; 3]) -> Self {
        let mut data = Vec::with_capacity(3 * width as usize * height as usize);
        for _ in 0..width as usize * height as usize {
            data.extend_from_slice(&colour);
        }
        Rgb8 {
            width,
            height,
            data,
        }
    }

    /// Set pixel `(x, y)`; outside the image nothing happens.
    pub fn set(&mut self, x: u32, y: u32, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            self.data[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Pixel `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Write as an 8-bit RGB PNG.
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        let f = File::create(path).map_err(|e| RenderError::file(path, e))?;
        let mut enc = png::Encoder::new(BufWriter::new(f), self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| RenderError::file(path, e))?;
        w.write_image_data(&self.data)
            .map_err(|e| RenderError::file(path, e))?;
        w.finish().map_err(|e| RenderError::file(path, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_keeps_counts_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.exr");
        let mut c = Channels::new(3, 2);
        c.push("steps", vec![0.0, 1.0, 255.0, 256.0, 16_777_216.0, 7.0])
            .unwrap();
        c.push("prims", vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert!(c.push("bad", vec![1.0]).is_err());
        c.write_exr(&p).unwrap();
        let r = Channels::read_exr(&p).unwrap();
        assert_eq!((r.width, r.height), (3, 2));
        assert_eq!(r.get("steps"), c.get("steps"));
        assert_eq!(r.get("prims"), c.get("prims"));
    }

    #[test]
    fn png_writes_and_bad_path_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = Rgb8::filled(4, 3, [1, 2, 3]);
        img.set(3, 2, [9, 9, 9]);
        img.set(7, 7, [9, 9, 9]);
        assert_eq!(img.get(3, 2), [9, 9, 9]);
        let p = dir.path().join("a.png");
        img.write_png(&p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let e = img.write_png(&dir.path().join("no/such/dir.png"));
        assert!(e.unwrap_err().to_string().contains("no/such/dir.png"));
    }
}
