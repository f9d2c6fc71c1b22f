//! Writing results: the PNG and the `--aov` EXRs of DESIGN.md. Every file is written to a
//! temporary name in its folder and renamed, so a failure never leaves half a file.

use crate::render::FrameImages;
use anyhow::{Context as _, Result};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, WritableImage,
};
use std::path::Path;

fn temp_path(path: &Path) -> std::path::PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Writes through a temporary file renamed into place.
fn atomic_write(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    match write(&tmp) {
        Ok(()) => {
            std::fs::rename(&tmp, path).with_context(|| format!("renaming into {}", path.display()))
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// The shaded image as an 8-bit RGBA PNG.
pub fn write_png(path: &Path, frame: &FrameImages) -> Result<()> {
    let bytes: Vec<u8> = frame.color.iter().flatten().copied().collect();
    let img = image::RgbaImage::from_raw(frame.width, frame.height, bytes)
        .context("image size does not match its pixels")?;
    atomic_write(path, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png)
            .with_context(|| format!("writing {}", path.display()))
    })
}

/// An EXR of 32-bit float channels named `names`, `channels[c][pixel]`.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    names: &[&str],
    channels: Vec<Vec<f32>>,
) -> Result<()> {
    let list: Vec<AnyChannel<FlatSamples>> = names
        .iter()
        .zip(channels)
        .map(|(n, data)| AnyChannel::new(*n, FlatSamples::F32(data)))
        .collect();
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list.into()),
    );
    let image = Image::from_layer(layer);
    atomic_write(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("writing {}", path.display()))
    })
}

/// `DIR/visibility.exr` (one channel `Y`), `DIR/position.exr` (RGBA), `DIR/normal.exr` (RGB).
pub fn write_aovs(dir: &Path, frame: &FrameImages) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("creating AOV folder {}", dir.display()))?;
    let (w, h) = (frame.width, frame.height);
    write_exr(
        &dir.join("visibility.exr"),
        w,
        h,
        &["Y"],
        vec![frame.visibility.clone()],
    )?;
    let pos: Vec<Vec<f32>> = (0..4)
        .map(|c| frame.position.iter().map(|p| p[c]).collect())
        .collect();
    write_exr(&dir.join("position.exr"), w, h, &["R", "G", "B", "A"], pos)?;
    let nrm: Vec<Vec<f32>> = (0..3)
        .map(|c| frame.normal.iter().map(|p| p[c]).collect())
        .collect();
    write_exr(&dir.join("normal.exr"), w, h, &["R", "G", "B"], nrm)?;
    Ok(())
}
