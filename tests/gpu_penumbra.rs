//! penumbra-map's GPU geometry path (`GpuSilhouettes::new_penumbra`: the smoothie path's
//! silhouette classification, then compute emitters writing cones and sheets straight into
//! a vertex buffer drawn indirectly) against its CPU path (`extract` + `build_penumbra`):
//! the same triangles, the same images, partial rebuilds, the CLI switch.

mod common;

use common::{
    bowl, covered, cube, max_colour_diff, max_visibility_diff, pixel_at, small, softshadow,
    with_caster, Gpu,
};
use glam::{Mat4, Vec3};
use softshadow::frustum::fit_light;
use softshadow::output::FrameImages;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::{Settings, SilhouettePath};
use softshadow::silhouette::penumbra::{build_penumbra, cone_spread, PenumbraVertex};
use softshadow::silhouette::{extract, light_point, Adjacency};
use softshadow::technique::penumbra_map::cone_base_depth;
use std::collections::BTreeSet;

const TECHNIQUE: &str = "penumbra-map";

fn settings(path: SilhouettePath) -> Settings {
    Settings {
        silhouettes: path,
        ..small(128, 512)
    }
}

/// One triangle: three vertices of 6 floats (position, zv_h, reach).
type Tri = [[f32; 6]; 3];

fn tris_of_floats(floats: &[f32]) -> Vec<Tri> {
    assert_eq!(floats.len() % 18, 0, "a whole number of triangles");
    floats
        .chunks_exact(18)
        .map(|t| std::array::from_fn(|v| std::array::from_fn(|k| t[6 * v + k])))
        .collect()
}

fn tris_of_vertices(vertices: &[PenumbraVertex]) -> Vec<Tri> {
    let floats: &[f32] = bytemuck::cast_slice(vertices);
    tris_of_floats(floats)
}

/// Largest difference between two triangles, relative to the size of the values, in
/// either winding: the penumbra pass draws with culling off, and a cone arc between two
/// parallel sheets (a sweep about 0, reaching `ARC_OVERLAP` past each) may turn either way
/// on the two devices.
fn tri_distance(a: &Tri, b: &Tri) -> f32 {
    let d = |b: &Tri| {
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .map(|(x, y)| (x - y).abs() / (1.0 + x.abs().max(y.abs())))
            .fold(0.0, f32::max)
    };
    d(b).min(d(&[b[0], b[2], b[1]]))
}

/// Matches every CPU triangle with a distinct GPU triangle (the GPU's order comes from
/// atomics); returns the worst match's distance.
fn match_triangles(name: &str, cpu: &[Tri], gpu: &[Tri]) -> f32 {
    assert_eq!(
        cpu.len(),
        gpu.len(),
        "{name}: {} CPU triangles, {} GPU triangles",
        cpu.len(),
        gpu.len()
    );
    let mut used = vec![false; gpu.len()];
    let mut worst = 0.0f32;
    for (i, c) in cpu.iter().enumerate() {
        let best = gpu
            .iter()
            .enumerate()
            .filter(|(j, _)| !used[*j])
            .map(|(j, g)| (j, tri_distance(c, g)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let (j, d) = best.unwrap_or_else(|| panic!("{name}: CPU triangle {i} unmatched"));
        assert!(
            d < 1e-4,
            "{name}: CPU triangle {i} {c:?} nearest GPU {:?} ({d})",
            gpu[j]
        );
        used[j] = true;
        worst = worst.max(d);
    }
    worst
}

#[test]
fn gpu_cones_and_sheets_are_the_cpu_triangles() {
    let gpu = Gpu::new();
    // And under a sun: cones about each vertex's own axis, k = 1, reach in world units.
    let scenes = [
        with_caster(cube(), "cube"),
        with_caster(bowl(), "open bowl"),
        Scene::load("dense").unwrap(),
        Scene::load("sun-courtyard").unwrap(),
    ];
    for scene in scenes {
        let name = scene.name.clone();
        let s = settings(SilhouettePath::Gpu);
        let light = fit_light(&scene);
        let radius = scene.light.radius;
        assert!(cone_spread(&light, radius) > 0.0);
        let from = light_point(&light);
        let z_far = cone_base_depth(&light);
        let mut r = Renderer::new(&gpu.ctx, scene.clone(), TECHNIQUE, s).unwrap();
        r.render().unwrap();
        // The smoothie path's classification: exactly the CPU's silhouette edges.
        let edges = r
            .read_gpu_silhouettes()
            .unwrap()
            .expect("penumbra-map on the GPU path exposes its silhouettes");
        for (object, gpu_edges) in edges {
            let o = &scene.objects[object];
            let adj = Adjacency::build(&o.mesh).unwrap();
            let cpu: BTreeSet<(u32, u32, u32)> = extract(&adj, o.transform, from)
                .iter()
                .map(|e| (e.edge, e.a, e.b))
                .collect();
            let gpu: BTreeSet<(u32, u32, u32)> = gpu_edges.into_iter().collect();
            assert_eq!(cpu, gpu, "{name}/{}: silhouette edges", o.name);
        }
        let found = r
            .read_gpu_geometry()
            .unwrap()
            .expect("penumbra-map on the GPU path exposes its geometry");
        let casters = scene.objects.iter().filter(|o| o.role.casts()).count();
        assert_eq!(found.len(), casters, "{name}: every caster");
        for (object, floats) in found {
            let o = &scene.objects[object];
            let adj = Adjacency::build(&o.mesh).unwrap();
            let sil = extract(&adj, o.transform, from);
            let cpu = build_penumbra(&adj, &sil, o.transform, &light, radius, z_far);
            let name = format!("{name}/{}", o.name);
            assert!(cpu.sheets > 0 && cpu.cones > 0, "{name}: no CPU geometry");
            assert_eq!(cpu.skipped_vertices, 0, "{name}");
            let worst = match_triangles(
                &name,
                &tris_of_vertices(&cpu.vertices),
                &tris_of_floats(&floats),
            );
            eprintln!(
                "{name}: {} triangles ({} cones, {} sheets), worst relative difference {worst:e}",
                cpu.vertices.len() / 3,
                cpu.cones,
                cpu.sheets
            );
        }
    }
}

fn scenes() -> Vec<Scene> {
    vec![
        with_caster(cube(), "cube"),
        with_caster(bowl(), "open bowl"),
        Scene::load("bunny").unwrap(),
        Scene::load("dense").unwrap(),
        // (sun-bunny's high sun casts too small a shadow at this size: 17 soft pixels more
        // than hard, measured.)
        Scene::load("sun-courtyard").unwrap(),
    ]
}

fn soft(v: &[f32]) -> usize {
    v.iter().filter(|&&x| x > 0.05 && x < 0.95).count()
}

/// The ground point under the light ray through the scene's first caster's origin (in its
/// umbra), and one as far on the light's side of the caster (lit).
fn umbra_and_lit(scene: &Scene) -> (Vec3, Vec3) {
    let light = scene.light.position;
    let caster = scene.objects.iter().find(|o| o.role.casts()).unwrap();
    let c = caster.transform.transform_point3(Vec3::ZERO);
    let t = light.y / (light.y - c.y);
    let umbra = light + t * (c - light);
    let lit = Vec3::new(2.0 * c.x - umbra.x, 0.0, 2.0 * c.z - umbra.z);
    (umbra, lit)
}

#[test]
fn gpu_and_cpu_penumbra_maps_render_the_same_image() {
    let gpu = Gpu::new();
    for scene in scenes() {
        let name = scene.name.clone();
        let render = |path, technique| {
            gpu.render_frames(scene.clone(), technique, settings(path), 1)
                .0
        };
        let cpu: FrameImages = render(SilhouettePath::Cpu, TECHNIQUE);
        let on_gpu = render(SilhouettePath::Gpu, TECHNIQUE);
        let hard = render(SilhouettePath::Cpu, "hard");
        let max_diff = max_visibility_diff(&cpu, &on_gpu);
        let over = cpu
            .visibility
            .iter()
            .zip(&on_gpu.visibility)
            .filter(|(a, b)| (*a - *b).abs() > 1.0 / 255.0)
            .count();
        eprintln!("{name}: max difference {max_diff}, {over} pixels over one level");
        // The geometry agrees to ~1e-5 relative (gpu_cones_and_sheets_are_the_cpu_triangles:
        // GPU sin/cos and fused multiply-adds); the triangles' order does not matter (MIN
        // blending). Those last bits still move a rasterised edge or a steep Eq. 1 value by
        // a little more than one 8-bit level at a rare pixel (1 of 16384 in `dense`, 0.0043),
        // hence: every pixel within two levels, at most two beyond one.
        assert!(
            max_diff <= 2.0 / 255.0 && over <= 2,
            "{name}: GPU and CPU penumbra maps differ by {max_diff} ({over} pixels over one level)"
        );
        let max_colour = max_colour_diff(&cpu, &on_gpu);
        assert!(max_colour <= 2, "{name}: colours differ by {max_colour}");
        // Both drew a penumbra that hard shadows do not have.
        for (path, img) in [("cpu", &cpu), ("gpu", &on_gpu)] {
            assert!(
                soft(&img.visibility) > soft(&hard.visibility) + 20,
                "{name}/{path}: no penumbra ({} soft pixels vs hard {})",
                soft(&img.visibility),
                soft(&hard.visibility)
            );
        }
        // Single-caster scenes: lit beside the caster, umbra under it (the hard shadow).
        if name == "cube" || name == "open bowl" {
            let (umbra, lit) = umbra_and_lit(&scene);
            for (path, img) in [("cpu", &cpu), ("gpu", &on_gpu)] {
                let u = img.visibility[pixel_at(img, umbra)];
                let l = img.visibility[pixel_at(img, lit)];
                assert!(u < 0.02, "{name}/{path}: umbra at {umbra} has {u}");
                assert!(l > 0.98, "{name}/{path}: lit point {lit} has {l}");
                let penumbra = covered(img)
                    .into_iter()
                    .filter(|&i| img.visibility[i] > 0.1 && img.visibility[i] < 0.9)
                    .count();
                assert!(penumbra > 30, "{name}/{path}: {penumbra} penumbra pixels");
            }
        }
    }
}

#[test]
fn gpu_path_with_a_point_light_is_hard() {
    let gpu = Gpu::new();
    let scene = with_caster(cube(), "cube");
    let point = |path| Settings {
        light_radius: Some(0.0),
        ..settings(path)
    };
    let mut r = Renderer::new(
        &gpu.ctx,
        scene.clone(),
        TECHNIQUE,
        point(SilhouettePath::Gpu),
    )
    .unwrap();
    let t = r.render().unwrap();
    let sil = t
        .passes
        .iter()
        .find(|p| p.name == "penumbra-map/silhouettes")
        .expect("the GPU path's pass is listed");
    assert_eq!(sil.not_run.as_deref(), Some("light radius 0: hard shadows"));
    let on_gpu = r.read_back().unwrap();
    let cpu = gpu
        .render_frames(scene.clone(), TECHNIQUE, point(SilhouettePath::Cpu), 1)
        .0;
    assert_eq!(on_gpu.visibility, cpu.visibility);
    assert_eq!(soft(&on_gpu.visibility), soft(&cpu.visibility));
    // Hard: `hard`'s image, pixel for pixel (both test the same shadow map).
    let hard = gpu
        .render_frames(scene, "hard", point(SilhouettePath::Gpu), 1)
        .0;
    let shadowed = hard.visibility.iter().filter(|&&v| v < 0.5).count();
    assert!(shadowed > 100, "the cube casts a shadow: {shadowed} pixels");
    let off: Vec<usize> = (0..hard.visibility.len())
        .filter(|&i| (on_gpu.visibility[i] - hard.visibility[i]).abs() > 1e-3)
        .collect();
    assert!(
        off.is_empty(),
        "{} pixels differ from hard, e.g. {:?}",
        off.len(),
        off.iter()
            .take(5)
            .map(|&i| (on_gpu.visibility[i], hard.visibility[i]))
            .collect::<Vec<_>>()
    );
}

#[test]
fn a_moved_caster_rebuilds_only_its_own_cones_and_sheets() {
    let gpu = Gpu::new();
    let scene = Scene::load("boxes").unwrap();
    let casters: Vec<usize> = (0..scene.objects.len())
        .filter(|&i| scene.objects[i].role.casts())
        .collect();
    assert!(casters.len() >= 2);
    // The lower box: moving it changes neither near nor far (see gpu_silhouettes.rs).
    let lower = casters[0];
    let s = settings(SilhouettePath::Gpu);
    let mut r = Renderer::new(&gpu.ctx, scene, TECHNIQUE, s.clone()).unwrap();
    r.render().unwrap();
    assert_eq!(r.gpu_silhouettes_rebuilt(), Some(casters.len()));
    let before = r.read_gpu_geometry().unwrap().unwrap();
    let (near, far) = (fit_light(&r.scene).near, fit_light(&r.scene).far);
    r.scene.objects[lower].transform =
        Mat4::from_translation(Vec3::new(0.3, 0.0, -0.2)) * r.scene.objects[lower].transform;
    assert_eq!(fit_light(&r.scene).near, near);
    assert_eq!(fit_light(&r.scene).far, far);
    let moved = r.render().unwrap();
    assert!(moved
        .passes
        .iter()
        .any(|p| p.name == "penumbra-map/silhouettes" && p.not_run.is_none()));
    assert_eq!(
        r.gpu_silhouettes_rebuilt(),
        Some(1),
        "only the moved caster"
    );
    let after = r.read_gpu_geometry().unwrap().unwrap();
    for ((object, old), (_, new)) in before.iter().zip(&after) {
        if *object == lower {
            assert_ne!(old, new, "the moved box's geometry was rebuilt");
        } else {
            // Kept as it was, not rebuilt (bit for bit, and in the same order).
            assert_eq!(old, new, "object {object} was kept");
        }
    }
    let partial = r.read_back().unwrap();
    let fresh = gpu
        .render_frames(r.scene.clone(), TECHNIQUE, s.clone(), 1)
        .0;
    assert_eq!(partial.visibility, fresh.visibility);

    // Nothing moved: the GPU pass is left out, the geometry kept.
    let t = r.render().unwrap();
    let sil = t
        .passes
        .iter()
        .find(|p| p.name == "penumbra-map/silhouettes")
        .unwrap();
    assert_eq!(sil.not_run.as_deref(), Some("light and casters unchanged"));
    assert_eq!(r.read_back().unwrap().visibility, partial.visibility);

    // A moving receiver changes no silhouette, but it moves the light's far plane and with
    // it the cone bases (Z_far = 0.995 far): every caster is rebuilt.
    let ground = (0..r.scene.objects.len())
        .find(|i| !casters.contains(i))
        .unwrap();
    r.scene.objects[ground].transform =
        Mat4::from_translation(Vec3::new(0.0, -0.05, 0.0)) * r.scene.objects[ground].transform;
    assert_ne!(fit_light(&r.scene).far, far);
    let t = r.render().unwrap();
    assert!(t
        .passes
        .iter()
        .any(|p| p.name == "penumbra-map/silhouettes" && p.not_run.is_none()));
    assert_eq!(r.gpu_silhouettes_rebuilt(), Some(casters.len()));
    let partial = r.read_back().unwrap();
    let fresh = gpu.render_frames(r.scene.clone(), TECHNIQUE, s, 1).0;
    assert_eq!(partial.visibility, fresh.visibility, "receiver move");
}

#[test]
fn cli_selects_the_penumbra_map_path() {
    let dir = std::env::temp_dir().join(format!("softshadow-pmgpu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for path in ["gpu", "cpu"] {
        let out = dir.join(format!("{path}.png"));
        let o = softshadow(&[
            "render",
            "--scene",
            "boxes",
            "--technique",
            TECHNIQUE,
            "--width",
            "64",
            "--height",
            "64",
            "--shadow-res",
            "128",
            "--silhouettes",
            path,
            "--timings",
            "--out",
            out.to_str().unwrap(),
        ]);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The GPU path is a timed pass, the CPU path CPU work.
        let (timed, cpu) = (
            stdout.contains("pass penumbra-map/silhouettes"),
            stdout.contains("cpu  penumbra-map/silhouettes"),
        );
        assert_eq!((timed, cpu), (path == "gpu", path == "cpu"), "{stdout}");
        assert!(out.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
