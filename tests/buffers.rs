//! `render --buffers DIR`: every technique of the registry lists its light-space buffers
//! (`Technique::light_buffers`), each with channel names that say what they hold and values
//! that fit those names; the command writes them as EXRs with those channel names, and says
//! so when a technique has none.

mod common;

use common::{small, softshadow, Gpu};
use softshadow::gpu::passes::FAR_DEPTH;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use softshadow::technique::TECHNIQUES;

fn tiny() -> Settings {
    Settings {
        occluder_res: 64,
        ..small(32, 64)
    }
}

/// Checks one channel by what its name says it holds; `what` names it in failures.
fn check_channel(what: &str, name: &str, values: &[f32]) {
    assert!(
        values.iter().all(|v| v.is_finite()),
        "{what}: non-finite values"
    );
    let min = values.iter().copied().fold(f32::INFINITY, f32::min);
    let max = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    if name.ends_with("depth") {
        // Linear distances from the light: positive, FAR_DEPTH where nothing was drawn, and
        // on `cylinder` something is drawn into every depth buffer.
        assert!(
            min > 0.0 && max <= FAR_DEPTH,
            "{what}: depths in {min}..{max}"
        );
        assert!(min < FAR_DEPTH * 0.5, "{what}: nothing drawn");
    } else if name.ends_with("_z") {
        // A depth buffer as stored (`hard`'s D32 map): z/w of the light's projection in
        // [0, 1], 1 (the clear) where nothing was drawn, something drawn on `cylinder`.
        assert!(min >= 0.0 && max <= 1.0, "{what}: depths in {min}..{max}");
        assert!(min < 1.0, "{what}: nothing drawn");
    } else if ["alpha", "intensity", "fraction"].contains(&name) {
        // Fractions of the light, 1 = lit: the cylinder's shadow makes some of it darker.
        assert!(min >= 0.0 && max <= 1.0, "{what}: values in {min}..{max}");
        assert!(min < 1.0, "{what}: no shadow at all");
    } else if name == "occluded_fraction" {
        // The fraction of a bitmask's light samples hidden (ssm-bitmask), 1 = umbra: in
        // [0, 1], and the cylinder hides some of the light somewhere.
        assert!(min >= 0.0 && max <= 1.0, "{what}: values in {min}..{max}");
        assert!(max > 0.0, "{what}: no occlusion at all");
    } else if name.ends_with("visibility") {
        // A visibility, 1 = lit (plateaus-centred's coverage, and its inner values as the
        // profile's linear stand-in (1 - s) / 2): darker somewhere.
        assert!(min >= 0.0 && max <= 1.0, "{what}: values in {min}..{max}");
        assert!(min < 1.0, "{what}: no shadow at all");
    } else if name == "outer_share" {
        // A centred form's outer share (glsl/common/penumbra.glsl), -1 lit, 0 the hard
        // edge: somewhere inside a penumbra.
        assert!(min >= -1.0 && max <= 0.0, "{what}: values in {min}..{max}");
        assert!(max > -1.0, "{what}: no penumbra at all");
    } else if name == "inner_share" {
        // A centred form's inner share, 1 umbra (and where none was drawn), below 0 where a
        // thin blocker's far side lets light through: somewhere inside a penumbra.
        assert!(min >= -1.0 && max <= 1.0, "{what}: values in {min}..{max}");
        assert!(min < 1.0, "{what}: no penumbra at all");
    } else if name.ends_with("occlusion") {
        // Summed micro-patch occlusion: non-negative, not clamped, and somewhere positive.
        assert!(min >= 0.0, "{what}: negative occlusion {min}");
        assert!(max > 0.0, "{what}: no occlusion at all");
    } else if name.ends_with("nearness") {
        // 1 - depth / far (penumbra-map-centred's inner receiver): in [0, 1], and on
        // `cylinder` some inner penumbra was drawn (below the clear, 1).
        assert!(min >= 0.0 && max <= 1.0, "{what}: values in {min}..{max}");
        assert!(min < 1.0, "{what}: nothing drawn");
    } else if name == "unused" {
        // A padding channel: its clear value everywhere.
        assert!(min == max, "{what}: values in {min}..{max}");
    } else {
        panic!("{what}: channel name '{name}' is not one this test knows");
    }
}

#[test]
fn every_technique_lists_its_light_buffers_with_named_channels() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    for info in TECHNIQUES {
        let t = info.name;
        let mut r = Renderer::new(&gpu.ctx, scene.clone(), t, tiny())
            .unwrap_or_else(|e| panic!("{t}: {e:#}"));
        r.render().unwrap_or_else(|e| panic!("{t}: {e:#}"));
        let names = r.technique_buffer_names();
        if t == "reference" {
            // Ray cast from the camera's pixels: nothing in light space.
            assert!(names.is_empty(), "reference lists {names:?}");
            continue;
        }
        assert!(!names.is_empty(), "{t} lists no light-space buffer");
        for name in &names {
            // `render --buffers` checks these file names against its inputs before any work.
            assert!(
                softshadow::technique::LIGHT_BUFFER_NAMES.contains(name),
                "{t}/{name}: not in technique::LIGHT_BUFFER_NAMES"
            );
            let b = r
                .read_technique_buffer(name)
                .unwrap_or_else(|e| panic!("{t}/{name}: {e:#}"));
            assert!(b.width > 0 && b.height > 0, "{t}/{name}: empty");
            assert_eq!(b.channels.len(), b.channel_names.len(), "{t}/{name}");
            let mut unique = b.channel_names.to_vec();
            unique.sort();
            unique.dedup();
            assert_eq!(
                unique.len(),
                b.channel_names.len(),
                "{t}/{name}: names repeat"
            );
            for (c, values) in b.channel_names.iter().zip(&b.channels) {
                assert_eq!(
                    values.len(),
                    (b.width * b.height) as usize,
                    "{t}/{name}/{c}"
                );
                check_channel(&format!("{t}/{name}/{c}"), c, values);
            }
            // The shared shadow map: the nearest surface of any role is never farther than
            // the nearest caster (casters are surfaces too).
            if b.channel_names == ["caster_depth", "surface_depth"] {
                let [caster, surface] = &b.channels[..] else {
                    unreachable!("two channel names, two channels (asserted above)")
                };
                assert!(
                    caster.iter().zip(surface).all(|(c, s)| s <= c),
                    "{t}/{name}: a surface behind the nearest caster"
                );
                assert!(
                    caster.iter().zip(surface).any(|(c, s)| s < c),
                    "{t}/{name}: no receiver in front of the far plane"
                );
            }
        }
        assert!(
            r.read_technique_buffer("no_such_buffer").is_err(),
            "{t}: an unknown buffer name must be an error"
        );
    }
}

/// The casters-only shadow map of the techniques that compare against the nearest caster
/// alone (pcf, pcss, plateaus) holds, texel for texel, the r channel of the map
/// of every object (smoothies, penumbra maps): the receivers it leaves out never write r.
/// And they were there to leave out: the full map's g is nearer than its r somewhere.
#[test]
fn casters_only_shadow_map_is_the_full_maps_caster_channel() {
    let gpu = Gpu::new();
    let settings = small(32, 128);
    for name in ["cylinder", "bunny", "fence"] {
        let scene = Scene::load(name).unwrap();
        let mut r = Renderer::new(&gpu.ctx, scene.clone(), "smoothies", settings.clone()).unwrap();
        r.render().unwrap();
        let full = r.read_technique_buffer("shadow_map").unwrap();
        assert_eq!(full.channel_names, ["caster_depth", "surface_depth"]);
        assert!(
            full.channels[1]
                .iter()
                .zip(&full.channels[0])
                .any(|(g, r)| g < r),
            "{name}: no receiver in front of the casters"
        );
        for t in ["pcf", "pcss", "plateaus"] {
            let mut r = Renderer::new(&gpu.ctx, scene.clone(), t, settings.clone()).unwrap();
            r.render().unwrap();
            let casters = r.read_technique_buffer("shadow_map").unwrap();
            assert_eq!(casters.channel_names, ["caster_depth"], "{t}");
            assert!(
                casters.channels[0] == full.channels[0],
                "{name}/{t}: the caster depths differ from the full map's"
            );
        }
    }
}

fn exr_channels(path: &std::path::Path) -> Vec<String> {
    let image = exr::prelude::read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    image.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect()
}

#[test]
fn render_buffers_writes_named_exrs_or_says_there_are_none() {
    let dir = std::env::temp_dir().join(format!("softshadow-buffers-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let png = dir.join("out.png");
    std::fs::create_dir_all(&dir).unwrap();
    let run = |technique: &str, sub: &str| {
        let out = softshadow(&[
            "render",
            "--technique",
            technique,
            "--width",
            "32",
            "--height",
            "32",
            "--shadow-res",
            "64",
            "--out",
            png.to_str().unwrap(),
            "--buffers",
            dir.join(sub).to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{technique}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };

    let stdout = run("smoothies", "smoothies");
    let sub = dir.join("smoothies");
    let mut files: Vec<String> = std::fs::read_dir(&sub)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["shadow_map.exr", "smoothie_buffer.exr"]);
    let mut shadow = exr_channels(&sub.join("shadow_map.exr"));
    shadow.sort();
    assert_eq!(shadow, ["caster_depth", "surface_depth"]);
    let mut smoothie = exr_channels(&sub.join("smoothie_buffer.exr"));
    smoothie.sort();
    assert_eq!(smoothie, ["alpha", "depth"]);
    assert!(
        stdout.contains("smoothie_buffer.exr (depth, alpha)"),
        "{stdout}"
    );

    let stdout = run("reference", "reference");
    assert!(
        stdout.contains("reference renders no light-space buffers"),
        "{stdout}"
    );
    assert!(!dir.join("reference").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
