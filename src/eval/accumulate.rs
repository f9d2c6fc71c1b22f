//! A second, independent estimate of the soft-shadow ground truth on the GPU: Heckbert &
//! Herf's (1997) average of K hard shadows, each rendered with the point light moved to one
//! of K points spread over the light's disc. It shares no code with the ray-cast reference
//! (rasterised shadow maps instead of BVH rays), so agreement between the two checks both.
//!
//! The K points follow a Vogel (golden-angle) spiral, r_k = R sqrt((k + 1/2) / K),
//! theta_k = k * 137.5 degrees: equal area per point, deterministic, no clumps. They lie
//! on the disc centred on the light perpendicular to the spotlight's axis (one disc for the
//! whole frame), where the reference's disc faces each shaded point: off the axis by an
//! angle a, that disc is seen foreshortened by cos a across one direction, so penumbrae
//! narrow by up to 1 - cos a (about 3% at the 15 degrees from the axis of the built-in
//! scenes' shadows). Each hard shadow has the `hard` technique's 2x2 filtered comparison
//! and its shadow-map aliasing, which averaging over K shifted maps blurs.

use crate::output::FrameImages;
use crate::render::Renderer;
use crate::scene::Scene;
use crate::settings::Settings;
use crate::vk::Context;
use anyhow::{bail, Context as _, Result};
use glam::{Vec2, Vec3};

/// Most hard shadows one estimate may average.
pub const MAX_K: u32 = 4096;

/// The K points of the Vogel spiral on the unit disc.
pub fn vogel_disc(k: u32) -> Vec<Vec2> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..k)
        .map(|i| {
            let r = ((i as f32 + 0.5) / k as f32).sqrt();
            let t = i as f32 * golden;
            Vec2::new(r * t.cos(), r * t.sin())
        })
        .collect()
}

/// Heckbert & Herf: the average of `k` hard-shadow visibilities with the point light at `k`
/// points spread over the disc of radius `radius` (see the module header), rendered through
/// `Renderer` with the `hard` technique at `settings`' resolutions. `visibility` and `color`
/// are the averages; `position` and `normal` are the camera's (the same in every frame).
pub fn heckbert_herf(
    ctx: &Context,
    scene: &Scene,
    radius: f32,
    settings: &Settings,
    k: u32,
) -> Result<FrameImages> {
    if k == 0 || k > MAX_K {
        bail!("Heckbert-Herf light count {k} is out of range: allowed 1..={MAX_K}");
    }
    if !radius.is_finite() || radius < 0.0 {
        bail!("Heckbert-Herf light radius {radius} is out of range: allowed a finite value >= 0");
    }
    let base = scene.light;
    let axis = (base.target - base.position).normalize_or(Vec3::NEG_Z);
    let (u, v) = axis.any_orthonormal_pair();
    let settings = Settings {
        light_radius: Some(0.0),
        ..settings.clone()
    };
    let mut r = Renderer::new(ctx, scene.clone(), "hard", settings)
        .context("creating the hard renderer of the Heckbert-Herf estimate")?;
    let mut vis: Vec<f64> = Vec::new();
    let mut color: Vec<[f64; 4]> = Vec::new();
    let mut last = None;
    for (i, d) in vogel_disc(k).into_iter().enumerate() {
        // The target moves with the light so every sub-light keeps the spotlight's frustum.
        let offset = (u * d.x + v * d.y) * radius;
        r.scene.light.position = base.position + offset;
        r.scene.light.target = base.target + offset;
        r.render()
            .with_context(|| format!("rendering hard shadow {} of {k}", i + 1))?;
        let img = r.read_back()?;
        if vis.is_empty() {
            vis = vec![0.0; img.visibility.len()];
            color = vec![[0.0; 4]; img.color.len()];
        }
        for (a, &x) in vis.iter_mut().zip(&img.visibility) {
            *a += x as f64;
        }
        for (a, c) in color.iter_mut().zip(&img.color) {
            for (ai, &ci) in a.iter_mut().zip(c) {
                *ai += ci as f64;
            }
        }
        last = Some(img);
    }
    let Some(mut img) = last else {
        bail!("Heckbert-Herf estimate rendered no frame");
    };
    let kf = k as f64;
    img.visibility = vis.iter().map(|&a| (a / kf) as f32).collect();
    img.color = color
        .iter()
        .map(|c| c.map(|x| (x / kf).round().clamp(0.0, 255.0) as u8))
        .collect();
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vogel_points_cover_the_disc_evenly() {
        let pts = vogel_disc(256);
        assert!(pts.iter().all(|p| p.length() <= 1.0));
        // Equal area per point: a quarter of them inside radius 1/2, and balanced halves.
        let inner = pts.iter().filter(|p| p.length() < 0.5).count();
        assert_eq!(inner, 64);
        let right = pts.iter().filter(|p| p.x > 0.0).count();
        assert!((118..=138).contains(&right), "{right}");
        let mean = pts.iter().copied().sum::<Vec2>() / pts.len() as f32;
        assert!(mean.length() < 0.02, "{mean}");
    }
}
