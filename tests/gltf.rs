//! glTF scenes: a file written here (a box above a plane, a spot light and a camera, nodes
//! with rotations under a parent transform) renders like the same scene in TOML, as
//! `.gltf` + `.bin` and as `.glb`; broken and unsupported files give one clear error; a
//! built-in scene exported to `.glb` loads back and renders the same visibility.

mod common;

use common::{small, softshadow, Gpu};
use glam::{Mat3, Quat, Vec3};
use serde_json::{json, Value};
use softshadow::scene::{export_gltf, primitives, Mesh, Role, Scene};
use std::path::{Path, PathBuf};

fn tmp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("softshadow-gltf-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const LIGHT_POS: Vec3 = Vec3::new(-2.5, 6.0, 1.5);
const LIGHT_TARGET: Vec3 = Vec3::new(0.3, 0.5, -0.2);
const LIGHT_FOV: f32 = 60.0;
const LIGHT_RADIUS: f32 = 0.3;
const CAM_POS: Vec3 = Vec3::new(3.0, 5.0, 7.0);
const CAM_TARGET: Vec3 = Vec3::new(0.0, 0.5, 0.0);
const CAM_FOV: f32 = 45.0;

/// -Z towards `forward`, +Y as close to world up as it gets (glTF's camera and spot
/// convention), built independently of the exporter's helper.
fn facing(forward: Vec3) -> Quat {
    let f = forward.normalize();
    let r = f.cross(Vec3::Y).normalize();
    let u = r.cross(f);
    Quat::from_mat3(&Mat3::from_cols(r, u, -f))
}

fn box_mesh() -> Mesh {
    primitives::cuboid(Vec3::new(1.2, 0.6, 0.8))
}

fn ground_mesh() -> Mesh {
    primitives::plane(glam::Vec2::splat(8.0), 4)
}

/// The scene as TOML: the box at (0, 1.5, 0) turned 30 degrees about Y.
fn toml_scene() -> String {
    format!(
        "name = \"pair\"\n\
         [[object]]\nname = \"ground\"\nprimitive = \"plane\"\nsize = [8, 8]\nsegments = 4\nrole = \"receiver\"\n\
         [[object]]\nname = \"box\"\nprimitive = \"box\"\nsize = [1.2, 0.6, 0.8]\n\
         translate = [0, 1.5, 0]\nrotate_deg = [0, 30, 0]\nrole = \"caster\"\n\
         [light]\nposition = {:?}\ntarget = {:?}\nfov_deg = {LIGHT_FOV}\nradius = {LIGHT_RADIUS}\n\
         [camera]\nposition = {:?}\ntarget = {:?}\nfov_deg = {CAM_FOV}\n",
        LIGHT_POS.to_array(),
        LIGHT_TARGET.to_array(),
        CAM_POS.to_array(),
        CAM_TARGET.to_array()
    )
}

/// Appends `mesh` to `bin` and returns its (POSITION, NORMAL, indices) accessors.
fn add_mesh(
    bin: &mut Vec<u8>,
    views: &mut Vec<Value>,
    accs: &mut Vec<Value>,
    m: &Mesh,
) -> [usize; 3] {
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8]| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let b = m.bounds();
    let pv = view(bin, bytemuck::cast_slice(&m.positions));
    let nv = view(bin, bytemuck::cast_slice(&m.normals));
    let iv = view(bin, bytemuck::cast_slice(&m.indices));
    let n = accs.len();
    accs.push(
        json!({"bufferView": pv, "componentType": 5126, "count": m.positions.len(), "type": "VEC3",
                     "min": b.min.to_array(), "max": b.max.to_array()}),
    );
    accs.push(
        json!({"bufferView": nv, "componentType": 5126, "count": m.normals.len(), "type": "VEC3"}),
    );
    accs.push(json!({"bufferView": iv, "componentType": 5125, "count": m.indices.len(), "type": "SCALAR"}));
    [n, n + 1, n + 2]
}

/// The same scene as glTF JSON and its buffer. The box sits under a parent node that
/// lifts it by 1 and turns it 20 degrees; the box node adds 0.5 and 10 degrees. The light
/// node hangs under a parent translated by (0, 1, 0). `uri`: external buffer name.
fn gltf_scene(uri: Option<&str>) -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    let (mut views, mut accs) = (Vec::new(), Vec::new());
    let [bp, bn, bi] = add_mesh(&mut bin, &mut views, &mut accs, &box_mesh());
    let [gp, gn, gi] = add_mesh(&mut bin, &mut views, &mut accs, &ground_mesh());
    let rot_y = |deg: f32| Quat::from_rotation_y(deg.to_radians()).to_array();
    let lrot = facing(LIGHT_TARGET - LIGHT_POS);
    let crot = facing(CAM_TARGET - CAM_POS);
    let mut buffer = json!({"byteLength": bin.len()});
    if let Some(u) = uri {
        buffer["uri"] = json!(u);
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "name": "fill"},
            {"type": "spot", "spot": {"outerConeAngle": (LIGHT_FOV * 0.5).to_radians()},
             "extras": {"softshadow": {"radius": LIGHT_RADIUS}}}
        ]}},
        "scene": 0,
        "scenes": [{"name": "pair", "nodes": [0, 2, 3, 5]}],
        "nodes": [
            {"name": "rig", "translation": [0.0, 1.0, 0.0], "rotation": rot_y(20.0), "children": [1],
             "extras": {"softshadow": {"role": "caster"}}},
            {"name": "box", "mesh": 0, "translation": [0.0, 0.5, 0.0], "rotation": rot_y(10.0)},
            {"name": "ground", "mesh": 1, "extras": {"softshadow": {"role": "receiver"}}},
            {"name": "lamp", "translation": [0.0, 1.0, 0.0], "children": [4]},
            {"name": "spot", "translation": (LIGHT_POS - Vec3::Y).to_array(), "rotation": lrot.to_array(),
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "eye", "translation": CAM_POS.to_array(), "rotation": crot.to_array(), "camera": 0}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": CAM_FOV.to_radians(), "znear": 0.05}}],
        "meshes": [
            {"name": "box", "primitives": [{"attributes": {"POSITION": bp, "NORMAL": bn}, "indices": bi}]},
            {"name": "ground", "primitives": [{"attributes": {"POSITION": gp, "NORMAL": gn}, "indices": gi}]}
        ],
        "accessors": accs,
        "bufferViews": views,
        "buffers": [buffer]
    });
    (doc, bin)
}

fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn write_gltf(dir: &Path) -> PathBuf {
    let (doc, bin) = gltf_scene(Some("pair.bin"));
    std::fs::write(dir.join("pair.bin"), &bin).unwrap();
    let p = dir.join("pair.gltf");
    std::fs::write(&p, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    p
}

fn load(p: &Path) -> Scene {
    Scene::load(p.to_str().unwrap()).unwrap_or_else(|e| panic!("{e:#}"))
}

fn load_err(p: &Path) -> String {
    let e = format!("{:#}", Scene::load(p.to_str().unwrap()).unwrap_err());
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

fn dir_of(a: Vec3, b: Vec3) -> Vec3 {
    (b - a).normalize()
}

/// Objects, transforms, roles, light and camera agree with the TOML scene.
fn assert_same_scene(g: &Scene, t: &Scene) {
    assert_eq!(g.name, t.name);
    assert_eq!(g.objects.len(), t.objects.len());
    for to in &t.objects {
        let go = g
            .objects
            .iter()
            .find(|o| o.name == to.name)
            .unwrap_or_else(|| panic!("no object '{}' in the glTF scene", to.name));
        assert_eq!(go.role, to.role, "{}", to.name);
        assert_eq!(go.mesh.positions, to.mesh.positions, "{}", to.name);
        assert_eq!(go.mesh.indices, to.mesh.indices, "{}", to.name);
        assert!(
            go.transform.abs_diff_eq(to.transform, 1e-5),
            "{}: {} vs {}",
            to.name,
            go.transform,
            to.transform
        );
    }
    let (gl, tl) = (&g.light, &t.light);
    assert!((gl.position - tl.position).length() < 1e-5, "{gl:?} {tl:?}");
    assert!(dir_of(gl.position, gl.target).dot(dir_of(tl.position, tl.target)) > 1.0 - 1e-6);
    assert!((gl.fov_deg - tl.fov_deg).abs() < 1e-3, "{gl:?} {tl:?}");
    assert_eq!(gl.radius, tl.radius);
    let (gc, tc) = (&g.camera, &t.camera);
    assert!((gc.position - tc.position).length() < 1e-5);
    assert!(dir_of(gc.position, gc.target).dot(dir_of(tc.position, tc.target)) > 1.0 - 1e-6);
    assert!((gc.fov_deg - tc.fov_deg).abs() < 1e-3);
}

/// Mean and max |a - b| over pixels, and the share that differ by more than 0.05.
fn diff(a: &[f32], b: &[f32]) -> (f32, f32, f32) {
    assert_eq!(a.len(), b.len());
    let d: Vec<f32> = a.iter().zip(b).map(|(x, y)| (x - y).abs()).collect();
    let mean = d.iter().sum::<f32>() / d.len() as f32;
    let max = d.iter().copied().fold(0.0, f32::max);
    let off = d.iter().filter(|&&x| x > 0.05).count() as f32 / d.len() as f32;
    (mean, max, off)
}

#[test]
fn gltf_and_glb_render_like_the_toml_scene() {
    let d = tmp_dir("pair");
    let toml = d.join("pair.toml");
    std::fs::write(&toml, toml_scene()).unwrap();
    let t = load(&toml);
    let g = load(&write_gltf(&d));
    assert_same_scene(&g, &t);
    assert_eq!(
        g.objects.iter().find(|o| o.name == "box").unwrap().role,
        Role::Caster,
        "the box inherits its parent's role"
    );

    let (doc, bin) = gltf_scene(None);
    let glb_path = d.join("pair.glb");
    std::fs::write(&glb_path, glb(&doc, &bin)).unwrap();
    let b = load(&glb_path);
    assert_same_scene(&b, &t);

    let gpu = Gpu::new();
    let render = |s: Scene| gpu.render_frames(s, "pcss", small(128, 512), 1).0;
    let vt = render(t);
    let vg = render(g);
    let vb = render(b);
    // The shadow is there: some covered pixels in umbra, some lit.
    let dark = vt.visibility.iter().filter(|&&v| v < 0.1).count();
    let lit = vt.visibility.iter().filter(|&&v| v > 0.99).count();
    assert!(dark > 200 && lit > 2000, "dark {dark}, lit {lit}");
    for (what, v) in [("gltf", &vg), ("glb", &vb)] {
        let (mean, max, off) = diff(&v.visibility, &vt.visibility);
        assert!(
            // Measured: mean 2e-8, max 2e-5 (float rounding of the node rotations).
            mean < 1e-5 && max < 1e-3 && off == 0.0,
            "{what} vs toml: mean {mean}, max {max}, {off} off by > 0.05"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn light_radius_and_camera_defaults() {
    let d = tmp_dir("defaults");
    // Without the spot light (only the point light) and without a camera: the point light
    // gives the position; the aim, cone, radius and camera are fitted.
    let (mut doc, bin) = gltf_scene(Some("pair.bin"));
    std::fs::write(d.join("pair.bin"), &bin).unwrap();
    doc["nodes"][4]["extensions"]["KHR_lights_punctual"]["light"] = json!(0);
    doc["nodes"][5].as_object_mut().unwrap().remove("camera");
    let p = d.join("fitted.gltf");
    std::fs::write(&p, serde_json::to_vec(&doc).unwrap()).unwrap();
    let s = load(&p);
    assert!((s.light.position - LIGHT_POS).length() < 1e-5);
    assert!(s.light.radius > 0.0 && s.light.radius != LIGHT_RADIUS);
    assert_eq!(s.camera.fov_deg, 45.0);
    assert!(
        (s.camera.position - CAM_POS).length() > 0.1,
        "fitted, not the node's"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn broken_and_unsupported_files_give_one_clear_error() {
    let d = tmp_dir("bad");
    let write = |name: &str, bytes: &[u8]| {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let (doc, bin) = gltf_scene(None);
    let good = glb(&doc, &bin);

    let e = load_err(&write("cut.glb", &good[..good.len() / 2]));
    assert!(
        e.contains("cut.glb") && e.contains("not a valid glTF"),
        "{e}"
    );
    let e = load_err(&write(
        "syntax.gltf",
        b"{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [}",
    ));
    assert!(
        e.contains("syntax.gltf") && e.contains("not a valid glTF"),
        "{e}"
    );

    // A buffer shorter than its views: the reader would run past its end.
    let mut short = doc.clone();
    short["bufferViews"][1]["byteOffset"] = json!(bin.len());
    let e = load_err(&write("short.glb", &glb(&short, &bin)));
    assert!(e.contains("short.glb") && e.contains("NORMAL"), "{e}");

    let mut nan_bin = bin.clone();
    nan_bin[0..4].copy_from_slice(&f32::NAN.to_le_bytes());
    let e = load_err(&write("nan.glb", &glb(&doc, &nan_bin)));
    assert!(e.contains("non-finite") && e.contains("vertex 0"), "{e}");

    let mut lines = doc.clone();
    lines["meshes"][0]["primitives"][0]["mode"] = json!(1);
    let e = load_err(&write("lines.glb", &glb(&lines, &bin)));
    assert!(
        e.contains("lines.glb") && e.contains("mode Lines") && e.contains("mesh 0"),
        "{e}"
    );

    let mut morph = doc.clone();
    morph["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 0}]);
    let e = load_err(&write("morph.glb", &glb(&morph, &bin)));
    assert!(e.contains("morph targets are not supported"), "{e}");

    let mut skin = doc.clone();
    skin["skins"] = json!([{"joints": [2]}]);
    skin["nodes"][1]["skin"] = json!(0);
    let e = load_err(&write("skin.glb", &glb(&skin, &bin)));
    assert!(
        e.contains("node 1 ('box')") && e.contains("skinned meshes are not supported"),
        "{e}"
    );

    // Compression is decoded (tests/gltf_compressed.rs); instancing still is not.
    let mut instancing = doc.clone();
    instancing["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    let e = load_err(&write("instancing.glb", &glb(&instancing, &bin)));
    assert!(
        e.contains("EXT_mesh_gpu_instancing") && e.contains("does not support"),
        "{e}"
    );

    let mut role = doc.clone();
    role["nodes"][2]["extras"] = json!({"softshadow": {"role": "shadow"}});
    let e = load_err(&write("role.glb", &glb(&role, &bin)));
    assert!(
        e.contains("node 2 ('ground')") && e.contains("'shadow'"),
        "{e}"
    );

    // The command line: one `error:` line, a failure status, nothing rendered.
    let out_png = d.join("out.png");
    let o = softshadow(&[
        "render",
        "--scene",
        d.join("skin.glb").to_str().unwrap(),
        "--out",
        out_png.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{stderr}"
    );
    assert!(stderr.contains("skinned"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out_png.exists());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn exported_glb_loads_back_and_renders_the_same_visibility() {
    let d = tmp_dir("roundtrip");
    let gpu = Gpu::new();
    for name in ["boxes", "cylinder"] {
        let s = Scene::load(name).unwrap();
        let p = d.join(format!("{name}.glb"));
        export_gltf(&s, &p, 128, 128).unwrap();
        let back = load(&p);
        assert_eq!(back.name, s.name);
        assert_eq!(back.objects.len(), s.objects.len());
        for (a, b) in back.objects.iter().zip(&s.objects) {
            assert_eq!(a.name, b.name);
            assert_eq!(a.role, b.role);
            assert_eq!(a.albedo, b.albedo);
            assert_eq!(a.transform, b.transform, "{}", a.name);
            assert_eq!(a.mesh.positions, b.mesh.positions);
            assert_eq!(a.mesh.indices, b.mesh.indices);
        }
        assert_eq!(back.light.position, s.light.position);
        assert_eq!(back.light.radius, s.light.radius);
        assert_same_scene(&back, &s);

        let va = gpu.render_frames(s, "smoothies", small(128, 512), 1).0;
        let vb = gpu.render_frames(back, "smoothies", small(128, 512), 1).0;
        let (mean, max, off) = diff(&va.visibility, &vb.visibility);
        assert!(
            // Measured: mean 3e-7, max 2e-4 (light and camera directions through quaternions).
            mean < 1e-5 && max < 2e-3 && off == 0.0,
            "{name}: mean {mean}, max {max}, {off} off by > 0.05"
        );
    }

    // The .gltf form (JSON + .bin) and the command line.
    let p = d.join("boxes.gltf");
    let o = softshadow(&["export", "--scene", "boxes", "--gltf", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("boxes.bin").is_file());
    assert_same_scene(&load(&p), &Scene::load("boxes").unwrap());
    let o = softshadow(&[
        "export",
        "--scene",
        "boxes",
        "--gltf",
        d.join("x.fbx").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains(".glb or .gltf"));
    std::fs::remove_dir_all(&d).ok();
}

// ---------------------------------------------------------------------------------------
// Hostile files: node graphs built to exhaust the walk, sizes built to exhaust memory,
// paths that leave the scene's folder, transforms the two renderers read differently.
// ---------------------------------------------------------------------------------------

/// `doc` written as `name` in `dir`, with its buffer `bin` beside it as `NAME.bin`.
fn write_doc(dir: &Path, name: &str, doc: &Value, bin: &[u8]) -> PathBuf {
    let mut doc = doc.clone();
    let bin_name = format!("{name}.bin");
    if doc["buffers"][0].get("uri").is_some() {
        doc["buffers"][0]["uri"] = json!(bin_name);
    }
    std::fs::write(dir.join(&bin_name), bin).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_vec(&doc).unwrap()).unwrap();
    p
}

/// The pair scene with `extra` appended to its nodes: each new node's index is
/// `first + k` where `first` is returned.
fn with_nodes(extra: Vec<Value>) -> (Value, Vec<u8>, usize) {
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    let nodes = doc["nodes"].as_array_mut().unwrap();
    let first = nodes.len();
    nodes.extend(extra);
    (doc, bin, first)
}

#[test]
fn a_node_chain_deeper_than_the_limit_is_refused_not_a_stack_overflow() {
    let d = tmp_dir("chain");
    let n = 13_000;
    let chain: Vec<Value> = (0..n)
        .map(|k| {
            if k + 1 < n {
                json!({"children": [5 + 1 + k + 1]})
            } else {
                json!({"mesh": 0})
            }
        })
        .collect();
    let (mut doc, bin, first) = with_nodes(chain);
    assert_eq!(first, 6);
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(first));
    let e = load_err(&write_doc(&d, "chain.gltf", &doc, &bin));
    assert!(e.contains("levels deep") && e.contains("1000"), "{e}");
    // 900 levels are within the limit: the box at the bottom is an object.
    let chain: Vec<Value> = (0..900)
        .map(|k| {
            if k + 1 < 900 {
                json!({"name": format!("c{k}"), "children": [6 + k + 1]})
            } else {
                json!({"name": "deepbox", "mesh": 0})
            }
        })
        .collect();
    let (mut doc, bin, first) = with_nodes(chain);
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(first));
    let s = load(&write_doc(&d, "chain900.gltf", &doc, &bin));
    assert_eq!(s.objects.len(), 3);
    assert!(s.objects.iter().any(|o| o.name == "deepbox"));
}

#[test]
fn cycles_and_shared_children_are_refused_before_any_expansion() {
    let d = tmp_dir("graphs");
    // A cycle among 13,000 nodes, reachable from a root.
    let n = 13_000;
    let ring: Vec<Value> = (0..n)
        .map(|k| json!({"mesh": 0, "children": [6 + (k + 1) % n]}))
        .collect();
    let (mut doc, bin, _) = with_nodes(ring);
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(6));
    let e = load_err(&write_doc(&d, "ring.gltf", &doc, &bin));
    assert!(e.contains("cycle"), "{e}");
    // 40 levels, each node listing the next twice: 2^40 paths, with and without meshes.
    for mesh in [true, false] {
        let dag: Vec<Value> = (0..40)
            .map(|k| {
                let mut v = if k + 1 < 40 {
                    json!({"children": [6 + k + 1, 6 + k + 1]})
                } else {
                    json!({})
                };
                if mesh {
                    v["mesh"] = json!(0);
                }
                v
            })
            .collect();
        let (mut doc, bin, _) = with_nodes(dag);
        doc["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(json!(6));
        let e = load_err(&write_doc(&d, "twice.gltf", &doc, &bin));
        assert!(
            e.contains("node 7") && e.contains("at most one parent"),
            "{e}"
        );
    }
    // Two parents, each listing the child once.
    let (mut doc, bin, _) = with_nodes(vec![
        json!({"children": [8]}),
        json!({"children": [8]}),
        json!({"mesh": 0}),
    ]);
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .extend([json!(6), json!(7)]);
    let e = load_err(&write_doc(&d, "two.gltf", &doc, &bin));
    assert!(
        e.contains("node 8") && e.contains("node 6") && e.contains("node 7"),
        "{e}"
    );
    // A scene root that is also a child.
    let (mut doc, bin, _) = with_nodes(vec![json!({"children": [7]}), json!({"mesh": 0})]);
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .extend([json!(6), json!(7)]);
    let e = load_err(&write_doc(&d, "rootchild.gltf", &doc, &bin));
    assert!(
        e.contains("root node 7") || e.contains("its root node 7"),
        "{e}"
    );
}

#[test]
fn a_scene_over_the_triangle_limit_is_refused_before_reading() {
    let d = tmp_dir("many");
    // 2,000 meshes sharing one buffer of 10,000 triangles: 20 million instances' worth,
    // above the 16,777,216 limit, declared in a file of a few hundred kilobytes.
    let tris = 10_000usize;
    let positions: Vec<[f32; 3]> = (0..tris * 3)
        .map(|k| [(k % 3) as f32, (k / 3) as f32 * 1e-3, ((k + 1) % 3) as f32])
        .collect();
    let bin: Vec<u8> = bytemuck::cast_slice(&positions).to_vec();
    // Each mesh with an accessor of its own, all over the same view.
    let meshes: Vec<Value> = (0..2000)
        .map(|k| json!({"primitives": [{"attributes": {"POSITION": k}}]}))
        .collect();
    let accessor = json!({"bufferView": 0, "componentType": 5126, "count": tris * 3, "type": "VEC3",
                          "min": [0.0, 0.0, 0.0], "max": [2.0, 10.0, 2.0]});
    let nodes: Vec<Value> = (0..2000).map(|k| json!({"mesh": k})).collect();
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": (0..2000).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": vec![accessor; 2000],
        "bufferViews": [{"buffer": 0, "byteLength": bin.len()}],
        "buffers": [{"byteLength": bin.len(), "uri": "x.bin"}]
    });
    let e = load_err(&write_doc(&d, "many.gltf", &doc, &bin));
    assert!(
        e.contains("16777216") && e.contains("limit"),
        "the limit is named: {e}"
    );
    // 1,500 of them (15 million triangles) load, as instances of one mesh read once.
    let mut fewer = doc.clone();
    fewer["scenes"][0]["nodes"] = json!((0..1500).collect::<Vec<_>>());
    let s = load(&write_doc(&d, "fewer.gltf", &fewer, &bin));
    assert_eq!(s.objects.len(), 1500);
    assert!(s
        .objects
        .iter()
        .all(|o| std::sync::Arc::ptr_eq(&o.mesh, &s.objects[0].mesh)));
    assert_eq!(s.triangle_count(), 1500 * tris);
}

#[test]
fn buffer_uris_stay_inside_the_scene_folder() {
    let root = tmp_dir("confine");
    let d = root.join("scenes");
    std::fs::create_dir_all(d.join("sub")).unwrap();
    let (doc, bin) = gltf_scene(Some("x.bin"));
    std::fs::write(root.join("outside.bin"), &bin).unwrap();
    std::fs::write(d.join("sub/inside.bin"), &bin).unwrap();
    let _ = std::fs::remove_file(d.join("sub/link.bin"));
    std::os::unix::fs::symlink(root.join("outside.bin"), d.join("sub/link.bin")).unwrap();
    let outside = root.join("outside.bin");
    let cases = [
        "../outside.bin".to_owned(),
        "%2e%2e/outside.bin".to_owned(),
        "sub/../../outside.bin".to_owned(),
        outside.display().to_string(),
        format!("file://{}", outside.display()),
        "sub/link.bin".to_owned(),
    ];
    let with_uri = |uri: &str| {
        let mut doc = doc.clone();
        doc["buffers"][0]["uri"] = json!(uri);
        let p = d.join("s.gltf");
        std::fs::write(&p, serde_json::to_vec(&doc).unwrap()).unwrap();
        p
    };
    for uri in &cases {
        let e = load_err(&with_uri(uri));
        assert!(
            e.contains("outside the scene file's folder") && e.contains("--allow-outside-paths"),
            "{uri}: {e}"
        );
        // Allowed, the same file loads.
        let s = Scene::load_with(
            with_uri(uri).to_str().unwrap(),
            &softshadow::scene::LoadOptions {
                allow_outside_paths: true,
            },
        )
        .unwrap_or_else(|e| panic!("{uri}: {e:#}"));
        assert_eq!(s.objects.len(), 2);
    }
    // Inside, through a subfolder, percent-encoded or not.
    assert_eq!(load(&with_uri("sub/inside.bin")).objects.len(), 2);
    assert_eq!(load(&with_uri("sub%2Finside.bin")).objects.len(), 2);
}

#[test]
fn buffers_that_are_not_regular_files_are_refused_unread() {
    let d = tmp_dir("special");
    let (doc, bin) = gltf_scene(Some("x.bin"));
    let fifo = d.join("fifo.bin");
    let _ = std::fs::remove_file(&fifo);
    assert!(std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    std::fs::create_dir_all(d.join("folder.bin")).unwrap();
    let allow = softshadow::scene::LoadOptions {
        allow_outside_paths: true,
    };
    for (uri, kind) in [
        ("fifo.bin", "FIFO"),
        ("folder.bin", "folder"),
        ("/dev/zero", "device"),
        ("/dev/urandom", "device"),
    ] {
        let mut doc = doc.clone();
        doc["buffers"][0]["uri"] = json!(uri);
        let p = d.join("s.gltf");
        std::fs::write(&p, serde_json::to_vec(&doc).unwrap()).unwrap();
        let e = format!(
            "{:#}",
            Scene::load_with(p.to_str().unwrap(), &allow).unwrap_err()
        );
        assert!(
            e.contains(kind) && e.contains("not a regular file"),
            "{uri}: {e}"
        );
    }
    let _ = bin;
}

#[test]
fn bytes_of_a_file_read_as_a_buffer_are_never_quoted() {
    let d = tmp_dir("leak");
    // A "buffer" whose bytes are text: as indices, every value is out of range.
    let secret = b"AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA".to_vec();
    let positions: Vec<[f32; 3]> = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    let mut bin: Vec<u8> = bytemuck::cast_slice(&positions).to_vec();
    let at = bin.len();
    bin.extend_from_slice(&secret);
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteLength": at},
            {"buffer": 0, "byteOffset": at, "byteLength": secret.len()}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": "x.bin"}]
    });
    let e = load_err(&write_doc(&d, "leak.gltf", &doc, &bin));
    assert!(e.contains("out of range"), "{e}");
    assert!(
        !e.contains(&0x4141_4141u32.to_string()),
        "an index value from the buffer is quoted: {e}"
    );
}

#[test]
fn a_byte_stride_smaller_than_an_element_is_refused_before_the_reader() {
    let d = tmp_dir("stride");
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["bufferViews"][0]["byteStride"] = json!(4);
    let e = load_err(&write_doc(&d, "stride.gltf", &doc, &bin));
    assert!(e.contains("byteStride 4") && e.contains("12 bytes"), "{e}");
    // An accessor that claims more elements than its view holds.
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["accessors"][0]["count"] = json!(1000);
    let e = load_err(&write_doc(&d, "count.gltf", &doc, &bin));
    assert!(e.contains("past the end of its buffer view"), "{e}");
    // Billions of them: refused by the limit before the range is even computed.
    doc["accessors"][0]["count"] = json!(4_000_000_000u64);
    let e = load_err(&write_doc(&d, "billions.gltf", &doc, &bin));
    assert!(e.contains("limit"), "{e}");
}

#[test]
fn loader_corner_cases_of_transforms_lights_and_extras() {
    let d = tmp_dir("corners");
    let (doc, bin) = gltf_scene(Some("x.bin"));
    let reference = load(&write_doc(&d, "base.gltf", &doc, &bin));
    // A projective node matrix: the rasteriser and the ray caster would disagree.
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["nodes"][2]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.5, 0, 0, 0, 1]);
    let e = load_err(&write_doc(&d, "proj.gltf", &doc, &bin));
    assert!(e.contains("node 2") && e.contains("not affine"), "{e}");
    // Extras nested 200 deep, on a node and on the light: valid glTF, loads the same.
    let mut deep = json!(1);
    for _ in 0..200 {
        deep = json!({ "k": [deep] });
    }
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["nodes"][1]["extras"] = json!({"other": deep.clone()});
    doc["extensions"]["KHR_lights_punctual"]["lights"][1]["extras"]["deep"] = deep.clone();
    doc["asset"]["extras"] = deep;
    let s = load(&write_doc(&d, "deep.gltf", &doc, &bin));
    assert_eq!(s.light, reference.light);
    assert_eq!(s.objects.len(), reference.objects.len());
    // JSON nested deeper than the limit: one clear line.
    let mut deeper = json!(1);
    for _ in 0..5000 {
        deeper = json!([deeper]);
    }
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["asset"]["extras"] = deeper;
    let e = load_err(&write_doc(&d, "deeper.gltf", &doc, &bin));
    assert!(e.contains("levels deep") && e.contains("1000"), "{e}");
    // A light node scaled by 1e-30 keeps its direction.
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["nodes"][4]["scale"] = json!([1e-30, 1e-30, 1e-30]);
    let s = load(&write_doc(&d, "tiny.gltf", &doc, &bin));
    let (a, b) = (
        dir_of(s.light.position, s.light.target),
        dir_of(reference.light.position, reference.light.target),
    );
    assert!((a - b).length() < 1e-5, "{a} vs {b}");
    // A scale of 0 has no direction at all.
    doc["nodes"][4]["scale"] = json!([0.0, 0.0, 0.0]);
    let e = load_err(&write_doc(&d, "zero.gltf", &doc, &bin));
    assert!(e.contains("no direction"), "{e}");
    // A cone too wide, said in the file's own unit.
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["outerConeAngle"] = json!(1.6);
    let e = load_err(&write_doc(&d, "wide.gltf", &doc, &bin));
    assert!(
        e.contains("outerConeAngle 1.6 rad") && !e.contains("fov_deg"),
        "{e}"
    );
    // A newline in a name is escaped: the error stays one line (load_err checks).
    let (mut doc, bin) = gltf_scene(Some("x.bin"));
    doc["nodes"][2]["name"] = json!("ground\nerror: injected");
    doc["nodes"][2]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.5, 0, 0, 0, 1]);
    let e = load_err(&write_doc(&d, "nl.gltf", &doc, &bin));
    assert!(e.contains("ground\\nerror: injected"), "{e}");
}
