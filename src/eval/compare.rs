//! `softshadow compare`: a port's visibility against ours (or the reference's), with the
//! docs/DESIGN.md error metrics, for a port's CI.
//!
//! Inputs: two `visibility.exr` (a folder means `FOLDER/visibility.exr`; one float channel,
//! `Y` or any single channel), and the `position.exr` (RGBA, A = 1 on surfaces) and
//! `normal.exr` (RGB the normal, A the spot factor) that `softshadow render --aov` writes,
//! from `--aov`, else the reference folder, else the test folder: they give the judged
//! pixels (on a surface, spot factor above 0: light can fall there) and, with the light's
//! centre (`--light`, or the light of `--scene`), the surfaces facing the light that
//! `mae_lit` and `p99_lit` count. A `normal.exr` without A (an older file, or a port's) is
//! judged on every covered pixel, with a warning. Two shaded PNGs give ꟻLIP.
//!
//! Every input is checked before anything is computed: same size, the expected channels,
//! finite values; each failure is one error line naming the file.

use super::metrics::{self, Errors};
use anyhow::{anyhow, bail, Context as _, Result};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Where the comparison reads its inputs.
#[derive(Clone, Debug, Default)]
pub struct CompareInputs {
    /// Reference visibility: a `visibility.exr` or a folder holding one.
    pub reference: PathBuf,
    /// The port's visibility: a `visibility.exr` or a folder holding one.
    pub test: PathBuf,
    /// Folder of `position.exr` and `normal.exr` (default: the reference's, else the test's).
    pub aov: Option<PathBuf>,
    /// The light, for the lit-surface mask.
    pub light: LightAt,
    /// Shaded images (PNG) for ꟻLIP: reference and test.
    pub reference_image: Option<PathBuf>,
    pub test_image: Option<PathBuf>,
}

/// Where the light is, for the lit-surface mask: a point light's centre (`--light`, a
/// spotlight scene's position) or the direction towards a sun (`--sun`, a sun scene's axis;
/// every surface point sees a sun along the same direction, so its far "position" would tilt
/// the mask across a wide scene).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightAt {
    Point(Vec3),
    Sun(Vec3),
}

impl Default for LightAt {
    fn default() -> Self {
        LightAt::Point(Vec3::ZERO)
    }
}

/// What `compare` measured.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub width: u32,
    pub height: u32,
    pub errors: Errors,
    /// Judged pixels whose surface faces the light: the pixels `mae_lit` could count. None
    /// means the comparison cannot judge anything (`compare` then warns and fails).
    pub facing_pixels: usize,
    /// Warnings about the inputs (one line each).
    pub warnings: Vec<String>,
    /// Share of the covered pixels with |v − v_ref| > 0.1.
    pub off_by_0_1: f64,
    /// Mean ꟻLIP of the test's shaded image against the reference's, when both were given.
    pub flip: Option<f64>,
    /// Steps in the visibility where the reference is smooth (`metrics::false_edges`).
    pub false_edges: metrics::FalseEdges,
    /// False-colour |v − v_ref| (`metrics::error_image`, full scale `DIFF_SCALE`), RGBA8.
    pub diff: Vec<[u8; 4]>,
}

/// The |v − v_ref| the difference image shows at full scale (red), as the bench's.
pub const DIFF_SCALE: f32 = super::bench::ERROR_SCALE;

/// A float EXR's channels by name, and its size.
struct Exr {
    width: usize,
    height: usize,
    channels: Vec<(String, Vec<f32>)>,
}

/// Largest side of an EXR read: the largest image Vulkan devices render.
const MAX_EXR_SIDE: usize = 16384;
/// Most samples (pixels times channels) of an EXR read.
const MAX_EXR_SAMPLES: u64 = 1 << 28;
/// How many decoded bytes one byte of an EXR file may hold: above the best ratio of any
/// compression the exr crate reads (deflate's is about 1032), so no real file is refused.
const MAX_EXR_RATIO: u64 = 2048;

fn read_exr(path: &Path) -> Result<Exr> {
    let name = crate::scene::input::shown_path(path);
    if !path.exists() {
        bail!("{name}: no such file");
    }
    let file_len = crate::scene::input::check_regular(path, &name)?.len();
    // The header's declared size, checked before the pixels are allocated.
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| anyhow!("{name}: not a readable EXR image: {e}"))?;
    for h in meta.headers.iter() {
        let (w, hgt) = (h.layer_size.width(), h.layer_size.height());
        let channels = h.channels.list.len() as u64;
        let samples = (w as u64)
            .saturating_mul(hgt as u64)
            .saturating_mul(channels);
        let bytes: u64 = h
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum::<u64>()
            .saturating_mul(w as u64)
            .saturating_mul(hgt as u64);
        if w > MAX_EXR_SIDE || hgt > MAX_EXR_SIDE || samples > MAX_EXR_SAMPLES {
            bail!(
                "{name}: declares {w}x{hgt} pixels with {channels} channel(s), above the limit of {MAX_EXR_SIDE} pixels a side and {MAX_EXR_SAMPLES} samples"
            );
        }
        if bytes > file_len.saturating_mul(MAX_EXR_RATIO) {
            bail!(
                "{name}: declares {w}x{hgt} pixels with {channels} channel(s) ({bytes} bytes), more than its {file_len} bytes can hold: a truncated or corrupt EXR"
            );
        }
    }
    let image = exr::prelude::read_first_flat_layer_from_file(path)
        .map_err(|e| anyhow!("{name}: not a readable EXR image: {e}"))?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            (
                c.name.to_string(),
                c.sample_data.values_as_f32().collect::<Vec<f32>>(),
            )
        })
        .collect();
    Ok(Exr {
        width,
        height,
        channels,
    })
}

impl Exr {
    fn channel_names(&self) -> String {
        let names: Vec<&str> = self.channels.iter().map(|(n, _)| n.as_str()).collect();
        names.join(", ")
    }

    /// The channels named `names`, in that order.
    fn take(&self, path: &Path, names: &[&str]) -> Result<Vec<&[f32]>> {
        names
            .iter()
            .map(|n| {
                self.channels
                    .iter()
                    .find(|(c, _)| c == n)
                    .map(|(_, v)| v.as_slice())
                    .ok_or_else(|| {
                        anyhow!(
                            "{}: needs channels {} but has {}",
                            path.display(),
                            names.join(", "),
                            self.channel_names()
                        )
                    })
            })
            .collect()
    }

    /// The one visibility channel: `Y`, or the only channel there is.
    fn visibility(&self, path: &Path) -> Result<Vec<f32>> {
        let v = match self.channels.iter().find(|(n, _)| n == "Y") {
            Some((_, v)) => v,
            None if self.channels.len() == 1 => &self.channels[0].1,
            None => bail!(
                "{}: a visibility image has one channel (Y), this one has {}",
                path.display(),
                self.channel_names()
            ),
        };
        finite(path, v)?;
        Ok(v.clone())
    }
}

fn finite(path: &Path, v: &[f32]) -> Result<()> {
    let bad = v.iter().filter(|x| !x.is_finite()).count();
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        bail!(
            "{}: {bad} non-finite value(s), the first at value {i} ({})",
            path.display(),
            v[i]
        );
    }
    Ok(())
}

/// `PATH` itself, or `PATH/file` when `PATH` is a folder.
fn in_folder(path: &Path, file: &str) -> PathBuf {
    if path.is_dir() {
        path.join(file)
    } else {
        path.to_path_buf()
    }
}

/// The folder of the AOVs: `--aov`, else the reference's folder when it has them, else the
/// test's.
fn aov_folder(inputs: &CompareInputs) -> Result<PathBuf> {
    if let Some(d) = &inputs.aov {
        return Ok(d.clone());
    }
    let folder = |p: &Path| -> PathBuf {
        if p.is_dir() {
            p.to_path_buf()
        } else {
            p.parent().map(Path::to_path_buf).unwrap_or_default()
        }
    };
    for d in [folder(&inputs.reference), folder(&inputs.test)] {
        if d.join("position.exr").is_file() && d.join("normal.exr").is_file() {
            return Ok(d);
        }
    }
    bail!(
        "no position.exr and normal.exr beside the reference or the test visibility: give \
         --aov DIR (softshadow render --aov DIR writes them)"
    )
}

fn check_size(path: &Path, e: &Exr, w: usize, h: usize, against: &Path) -> Result<()> {
    if (e.width, e.height) != (w, h) {
        bail!(
            "{} is {}x{} but {} is {w}x{h}: the images must have the same size",
            path.display(),
            e.width,
            e.height,
            against.display()
        );
    }
    Ok(())
}

fn read_png(path: &Path, w: usize, h: usize) -> Result<Vec<[u8; 4]>> {
    let img = image::open(path)
        .map_err(|e| anyhow!("{}: not a readable image: {e}", path.display()))?
        .to_rgba8();
    if (img.width() as usize, img.height() as usize) != (w, h) {
        bail!(
            "{} is {}x{} but the visibility images are {w}x{h}",
            path.display(),
            img.width(),
            img.height()
        );
    }
    Ok(img.pixels().map(|p| p.0).collect())
}

/// Reads, checks and compares (see the module docs).
pub fn compare(inputs: &CompareInputs) -> Result<Comparison> {
    match inputs.light {
        LightAt::Point(p) if !p.is_finite() => bail!("--light {p} must be finite"),
        LightAt::Sun(d) if !d.is_finite() || d.length_squared() <= 1e-12 => {
            bail!("--sun {d} must be a finite direction of non-zero length (towards the sun)")
        }
        _ => {}
    }

    let ref_path = in_folder(&inputs.reference, "visibility.exr");
    let test_path = in_folder(&inputs.test, "visibility.exr");
    let reference = read_exr(&ref_path)?;
    let (w, h) = (reference.width, reference.height);
    let test = read_exr(&test_path)?;
    check_size(&test_path, &test, w, h, &ref_path)?;
    let aov = aov_folder(inputs)?;
    let (pos_path, nrm_path) = (aov.join("position.exr"), aov.join("normal.exr"));
    let position = read_exr(&pos_path)?;
    check_size(&pos_path, &position, w, h, &ref_path)?;
    let normal = read_exr(&nrm_path)?;
    check_size(&nrm_path, &normal, w, h, &ref_path)?;

    let v_ref = reference.visibility(&ref_path)?;
    let v = test.visibility(&test_path)?;
    let p = position.take(&pos_path, &["R", "G", "B", "A"])?;
    let n = normal.take(&nrm_path, &["R", "G", "B"])?;
    for c in &p {
        finite(&pos_path, c)?;
    }
    for c in &n {
        finite(&nrm_path, c)?;
    }
    let mut warnings = Vec::new();
    let spot: Vec<f32> = match normal.take(&nrm_path, &["A"]) {
        Ok(a) => {
            finite(&nrm_path, a[0])?;
            a[0].to_vec()
        }
        Err(_) => {
            warnings.push(format!(
                "{} has no A channel (the spot factor): every covered pixel is judged, outside the light's cone too",
                nrm_path.display()
            ));
            vec![1.0; w * h]
        }
    };
    let positions: Vec<[f32; 4]> = (0..w * h)
        .map(|i| [p[0][i], p[1][i], p[2][i], p[3][i]])
        .collect();
    let normals: Vec<[f32; 3]> = (0..w * h).map(|i| [n[0][i], n[1][i], n[2][i]]).collect();

    let covered = metrics::judged(&positions, &spot);
    let facing = match inputs.light {
        LightAt::Point(p) => metrics::faces_light(&positions, &normals, p),
        LightAt::Sun(d) => metrics::faces_sun(&positions, &normals, d),
    };
    let facing_pixels = covered
        .iter()
        .zip(&facing)
        .filter(|(c, f)| **c && **f)
        .count();
    let errors = metrics::errors(&v, &v_ref, &covered, &facing);
    let false_edges = metrics::false_edges(&v, &v_ref, w, &positions, &normals, &covered, &facing);
    let off = v
        .iter()
        .zip(&v_ref)
        .zip(&covered)
        .filter(|((a, r), &c)| c && (*a - *r).abs() > 0.1)
        .count();
    let off_by_0_1 = if errors.covered_pixels == 0 {
        0.0
    } else {
        off as f64 / errors.covered_pixels as f64
    };
    let flip = match (&inputs.reference_image, &inputs.test_image) {
        (Some(r), Some(t)) => {
            let (r, t) = (read_png(r, w, h)?, read_png(t, w, h)?);
            Some(metrics::flip(&t, &r, w as u32, h as u32)?.mean)
        }
        (None, None) => None,
        _ => bail!("ꟻLIP needs both --reference-image and --test-image"),
    };
    let diff = metrics::error_image(&v, &v_ref, &covered, DIFF_SCALE);
    Ok(Comparison {
        width: w as u32,
        height: h as u32,
        errors,
        facing_pixels,
        warnings,
        off_by_0_1,
        flip,
        false_edges,
        diff,
    })
}

/// Writes the difference image as PNG (through a temporary name renamed into place).
pub fn write_diff(path: &Path, c: &Comparison) -> Result<()> {
    let mut publish = crate::output::Publish::new();
    publish.stage(path, |t| {
        let bytes: Vec<u8> = c.diff.iter().flatten().copied().collect();
        image::save_buffer_with_format(
            t,
            &bytes,
            c.width,
            c.height,
            image::ExtendedColorType::Rgba8,
            image::ImageFormat::Png,
        )
        .context("encoding the PNG")
    })?;
    publish.commit()
}

impl Comparison {
    /// The lines `compare` prints.
    pub fn report(&self) -> String {
        let e = &self.errors;
        let mut s = format!(
            "compare: {}x{}, {} covered pixels where light can fall, {} in the shadow region, {} of them facing the light\n",
            self.width, self.height, e.covered_pixels, e.shadow_pixels, e.lit_pixels
        );
        s += &format!("mae_lit     {:.6}\n", e.mae_lit);
        s += &format!("p99_lit     {:.6}\n", e.p99_lit);
        s += &format!("mae_shadow  {:.6}\n", e.mae_shadow);
        s += &format!(
            "off_0.1     {:.6}  (share of covered pixels with |v - v_ref| > 0.1)\n",
            self.off_by_0_1
        );
        let fe = &self.false_edges;
        s += &format!(
            "false_edges {:.3}  (per 1000 penumbra pixels: {} steps > {} where the reference steps < {}, {} penumbra pixels)\n",
            fe.per_1000,
            fe.pairs,
            metrics::EDGE_STEP,
            metrics::SMOOTH_STEP,
            fe.penumbra_pixels
        );
        if let Some(f) = self.flip {
            s += &format!("flip        {f:.6}\n");
        }
        s
    }
}
