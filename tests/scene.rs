//! Scene module integration tests: every built-in loads and validates with the expected
//! size, scene files round-trip, bad input gives one clear line, export matches the scene.

use glam::Vec3;
use softshadow::scene::{export_obj, Scene, BUILTIN_SCENES};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Silhouette edges of the casters seen from a point light: edges (welded by position)
/// between a lit and an unlit triangle, plus open edges of lit triangles.
fn silhouette_edges(scene: &Scene) -> usize {
    let l = scene.light.position;
    let mut count = 0;
    for o in scene.objects.iter().filter(|o| o.role.casts()) {
        let m = &o.mesh;
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let weld: Vec<u32> = m
            .positions
            .iter()
            .map(|p| {
                let n = ids.len() as u32;
                *ids.entry(p.to_array().map(f32::to_bits)).or_insert(n)
            })
            .collect();
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] =
                [0, 1, 2].map(|k| o.transform.transform_point3(m.positions[t[k] as usize]));
            let lit = (b - a).cross(c - a).dot(l - a) > 0.0;
            for k in 0..3 {
                let (u, v) = (weld[t[k] as usize], weld[t[(k + 1) % 3] as usize]);
                let e = edges.entry((u.min(v), u.max(v))).or_insert((0, 0));
                if lit {
                    e.0 += 1
                } else {
                    e.1 += 1
                }
            }
        }
        count += edges
            .values()
            .filter(|&&(a, b)| (a > 0 && b > 0) || (a + b == 1 && a == 1))
            .count();
    }
    count
}

#[test]
fn every_builtin_loads_and_validates() {
    for &name in BUILTIN_SCENES {
        let t0 = std::time::Instant::now();
        let s = Scene::load(name).unwrap_or_else(|e| panic!("{name}: {e:#}"));
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        s.validate().unwrap();
        assert_eq!(s.name, name);
        let tris = s.triangle_count();
        assert_eq!(s.world_triangles(false).len(), tris);
        let casters = s.caster_bounds().expect("has casters");
        let b = s.bounds();
        assert!(b.min.cmple(casters.min).all() && b.max.cmpge(casters.max).all());
        // The light looks down onto the casters and the camera sees them.
        assert!(
            s.light.position.y > casters.max.y,
            "{name}: light below casters"
        );
        match s.light.sun_angle_deg() {
            Some(a) => assert!(a > 0.0, "{name}: a sun of no angular radius"),
            None => assert!(s.light.radius > 0.0),
        }
        let sil = if tris < 200_000 {
            silhouette_edges(&s)
        } else {
            0
        };
        let l = s.light;
        let c = s.camera;
        println!(
            "{name:10} {tris:8} tris {sil:6} sil  {ms:7.1} ms  light {:?} -> {:?} fov {:.1} r {:.3}  camera {:?} -> {:?} fov {}",
            l.position, l.target, l.fov_deg, l.radius, c.position, c.target, c.fov_deg
        );
        match name {
            "primitives" => assert!((9_000..=11_000).contains(&tris), "{tris}"),
            "dense" => {
                assert!(tris >= 50_000, "{tris}");
                assert!(
                    (7_000..=14_000).contains(&sil),
                    "dense silhouette edges {sil}"
                );
            }
            "dense-1m" => assert!((900_000..=1_100_000).contains(&tris), "{tris}"),
            "bunny" => assert_eq!(tris, 3674 + 128),
            _ => assert!(tris >= 12),
        }
    }
}

#[test]
fn builtins_are_deterministic() {
    let a = Scene::load("dense").unwrap().world_triangles(true);
    let b = Scene::load("dense").unwrap().world_triangles(true);
    assert!(a == b);
}

fn example_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/example.toml")
}

#[test]
fn example_scene_file_loads() {
    let s = Scene::load(example_path().to_str().unwrap()).unwrap();
    assert!(s.objects.len() >= 3);
    assert!(s.caster_bounds().is_some());
}

fn tmp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("softshadow-scene-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn unknown_names_and_missing_files() {
    let e = format!("{:#}", Scene::load("no-such-scene").unwrap_err());
    assert!(
        e.contains("unknown scene 'no-such-scene'") && e.contains("cylinder, boxes"),
        "{e}"
    );
    let e = format!("{:#}", Scene::load("/nonexistent/dir/a.toml").unwrap_err());
    assert!(e.contains("/nonexistent/dir/a.toml"), "{e}");
    let e = format!("{:#}", Scene::load("/nonexistent/dir/a.obj").unwrap_err());
    assert!(e.contains("/nonexistent/dir/a.obj"), "{e}");
}

#[test]
fn bad_files_give_one_line_errors() {
    let d = tmp_dir("bad");
    let nan = d.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv 1 0 0\nv 0 NaN 1\nf 1 2 3\n").unwrap();
    let e = format!("{:#}", Scene::load(nan.to_str().unwrap()).unwrap_err());
    assert!(
        e.contains("nan.obj") && e.contains("vertex 3") && e.contains("non-finite"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");

    let key = d.join("key.toml");
    std::fs::write(
        &key,
        "[[object]]\nprimitive = \"box\"\n\n[light]\nposition = [0, 5, 0]\nradus = 0.2\n",
    )
    .unwrap();
    let e = format!("{:#}", Scene::load(key.to_str().unwrap()).unwrap_err());
    assert!(
        e.contains("radus") && e.contains("key.toml") && !e.contains('\n'),
        "{e}"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bare_obj_is_framed_on_a_ground_plane() {
    let d = tmp_dir("obj");
    let p = d.join("tet.obj");
    std::fs::write(
        &p,
        "v 0 1 0\nv 1 3 0\nv 0 3 1\nv -1 3 -1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n",
    )
    .unwrap();
    let s = Scene::load(p.to_str().unwrap()).unwrap();
    assert_eq!(s.objects.len(), 2);
    let ground = s.objects.iter().find(|o| o.name == "ground").unwrap();
    assert!((ground.world_bounds().min.y - 1.0).abs() < 1e-5);
    assert!(s.light.position.y > 3.0);
    std::fs::remove_dir_all(&d).ok();
}

/// The exported light and camera are the scene's, value for value.
fn assert_exported(l: &serde_json::Value, c: &serde_json::Value, s: &Scene) {
    let v3 = |v: &serde_json::Value| {
        let a = v.as_array().unwrap();
        assert_eq!(a.len(), 3, "{v}");
        Vec3::new(
            a[0].as_f64().unwrap() as f32,
            a[1].as_f64().unwrap() as f32,
            a[2].as_f64().unwrap() as f32,
        )
    };
    let near = |a: Vec3, b: Vec3, what: &str| {
        assert!(
            (a - b).length() <= 1e-5 * b.length().max(1.0),
            "{what}: {a} vs {b}"
        );
    };
    let num = |v: &serde_json::Value, want: f32, what: &str| {
        let x = v.as_f64().unwrap();
        assert!(
            (x - want as f64).abs() <= 1e-5 * (want.abs() as f64).max(1.0),
            "{what}: {x} vs {want}"
        );
    };
    near(v3(&l["position"]), s.light.position, "light position");
    near(v3(&l["target"]), s.light.target, "light target");
    num(&l["radius"], s.light.radius, "light radius");
    num(&l["fov_deg"], s.light.fov_deg, "light fov");
    near(v3(&c["position"]), s.camera.position, "camera position");
    near(v3(&c["target"]), s.camera.target, "camera target");
    near(v3(&c["up"]), s.camera.up, "camera up");
    num(&c["fov_deg"], s.camera.fov_deg, "camera fov");
}

#[test]
fn export_matches_the_scene() {
    let d = tmp_dir("export");
    for name in ["boxes", "bunny"] {
        let s = Scene::load(name).unwrap();
        let obj = d.join(format!("{name}.obj"));
        export_obj(&s, &obj, 640, 480).unwrap();
        let (models, _) = tobj::load_obj(&obj, &tobj::GPU_LOAD_OPTIONS).unwrap();
        let tris: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
        assert_eq!(tris, s.triangle_count());
        assert_eq!(models.len(), s.objects.len());
        // The exported vertices are world space: their bounds are the scene's.
        let mut lo = Vec3::INFINITY;
        let mut hi = Vec3::NEG_INFINITY;
        for m in &models {
            for p in m.mesh.positions.chunks_exact(3) {
                lo = lo.min(Vec3::new(p[0], p[1], p[2]));
                hi = hi.max(Vec3::new(p[0], p[1], p[2]));
            }
        }
        let b = s.bounds();
        assert!((lo - b.min).length() < 1e-3 && (hi - b.max).length() < 1e-3);

        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(format!("{name}.json"))).unwrap())
                .unwrap();
        let l = &j["lights"][0];
        let c = &j["camera"];
        assert_exported(l, c, &s);
        assert_eq!(c["width"], 640);
        assert_eq!(c["height"], 480);
    }
    // No temp files left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
    // A folder that does not exist fails cleanly.
    let s = Scene::load("cylinder").unwrap();
    assert!(export_obj(&s, &d.join("missing/x.obj"), 64, 64).is_err());
    std::fs::remove_dir_all(&d).ok();
}

/// The error of loading `p` with `opts`, checked to be one line.
fn load_err_with(p: &Path, opts: &softshadow::scene::LoadOptions) -> String {
    let e = format!(
        "{:#}",
        Scene::load_with(p.to_str().unwrap(), opts).unwrap_err()
    );
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n";

#[test]
fn mesh_paths_stay_inside_the_scene_folder_and_other_files_are_not_echoed() {
    let root = tmp_dir("confine");
    let d = root.join("scenes");
    std::fs::create_dir_all(d.join("sub")).unwrap();
    let secret = "API_KEY=hunter2-do-not-print";
    std::fs::write(root.join("secret.env"), format!("{secret}\n")).unwrap();
    std::fs::write(root.join("tri.obj"), TRI_OBJ).unwrap();
    std::fs::write(d.join("sub/tri.obj"), TRI_OBJ).unwrap();
    let link = d.join("sub/link.obj");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(root.join("tri.obj"), &link).unwrap();
    let scene = |mesh: &str| {
        let p = d.join("s.toml");
        std::fs::write(
            &p,
            format!("[[object]]\nmesh = {mesh:?}\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n"),
        )
        .unwrap();
        p
    };
    let confined = softshadow::scene::LoadOptions::default();
    let allow = softshadow::scene::LoadOptions {
        allow_outside_paths: true,
    };
    let outside = root.join("tri.obj").display().to_string();
    for mesh in ["../tri.obj", "sub/../../tri.obj", &outside, "sub/link.obj"] {
        let e = load_err_with(&scene(mesh), &confined);
        assert!(
            e.contains("outside the scene file's folder") && e.contains("--allow-outside-paths"),
            "{mesh}: {e}"
        );
        let s = Scene::load_with(scene(mesh).to_str().unwrap(), &allow)
            .unwrap_or_else(|e| panic!("{mesh}: {e:#}"));
        assert_eq!(s.objects[0].mesh.triangle_count(), 1);
    }
    assert_eq!(
        Scene::load(scene("sub/tri.obj").to_str().unwrap())
            .unwrap()
            .objects
            .len(),
        2
    );
    // /etc/passwd and a secret beside the folder: refused without reading; allowed, read
    // but never quoted.
    for mesh in ["/etc/passwd", "../secret.env"] {
        let e = load_err_with(&scene(mesh), &confined);
        assert!(e.contains("outside"), "{mesh}: {e}");
        let e = load_err_with(&scene(mesh), &allow);
        assert!(e.contains("not an OBJ file"), "{mesh}: {e}");
        assert!(
            !e.contains("hunter2") && !e.contains("root:"),
            "{mesh}: {e}"
        );
    }
    // A later junk line is quoted only as a short printable token.
    let junk = format!("{TRI_OBJ}\u{1b}[2J{}\n", "x".repeat(500));
    std::fs::write(d.join("junk.obj"), junk).unwrap();
    let e = load_err_with(&scene("junk.obj"), &confined);
    assert!(
        e.contains("unknown statement") && e.contains("\\u{1b}"),
        "{e}"
    );
    assert!(e.len() < 300, "clipped: {e}");
}

#[test]
fn inputs_that_are_not_regular_files_are_refused_unread() {
    let d = tmp_dir("special");
    for f in ["fifo.obj", "fifo.toml", "fifo.gltf"] {
        let _ = std::fs::remove_file(d.join(f));
        assert!(std::process::Command::new("mkfifo")
            .arg(d.join(f))
            .status()
            .unwrap()
            .success());
    }
    std::fs::create_dir_all(d.join("folder.obj")).unwrap();
    let confined = softshadow::scene::LoadOptions::default();
    let allow = softshadow::scene::LoadOptions {
        allow_outside_paths: true,
    };
    // As the scene itself.
    for f in ["fifo.obj", "fifo.toml", "fifo.gltf"] {
        let e = load_err_with(&d.join(f), &confined);
        assert!(
            e.contains("FIFO") && e.contains("not a regular file"),
            "{f}: {e}"
        );
    }
    // As a mesh of a scene file.
    for (mesh, kind) in [
        ("fifo.obj", "FIFO"),
        ("folder.obj", "folder"),
        ("/dev/zero", "device"),
        ("/dev/urandom", "device"),
    ] {
        let p = d.join("s.toml");
        std::fs::write(&p, format!("[[object]]\nmesh = {mesh:?}\n")).unwrap();
        let e = load_err_with(&p, &allow);
        assert!(
            e.contains(kind) && e.contains("not a regular file"),
            "{mesh}: {e}"
        );
    }
}

#[test]
fn scene_totals_are_bounded_before_building_and_names_stay_one_line() {
    let d = tmp_dir("limits");
    // A single sphere at the tessellation cap is 33 million triangles: refused before built.
    let p = d.join("big.toml");
    std::fs::write(
        &p,
        "[[object]]\nprimitive = \"sphere\"\nsegments = 4096\nrings = 4096\n",
    )
    .unwrap();
    let e = load_err_with(&p, &Default::default());
    assert!(e.contains("16777216") && e.contains("limit"), "{e}");
    // 200 instances of a 131,072-triangle plane: 26 million, refused at the one that crosses.
    let mut text = String::new();
    for _ in 0..200 {
        text.push_str("[[object]]\nprimitive = \"plane\"\nsegments = 256\n");
    }
    std::fs::write(&p, text).unwrap();
    let e = load_err_with(&p, &Default::default());
    assert!(e.contains("object 129") && e.contains("limit"), "{e}");
    // A newline in an object or scene name is escaped.
    std::fs::write(
        &p,
        "name = \"a\\nb\"\n[[object]]\nname = \"box\\nerror: x\"\nprimitive = \"box\"\nalbedo = [-1, 0, 0]\n",
    )
    .unwrap();
    let e = load_err_with(&p, &Default::default());
    assert!(e.contains("box\\nerror: x"), "{e}");
    // A TOML value pasted from elsewhere is clipped in the parser's message.
    std::fs::write(
        &p,
        format!(
            "[[object]]\nprimitive = \"box\"\nrole = \"{}\"\n",
            "y".repeat(5000)
        ),
    )
    .unwrap();
    let e = load_err_with(&p, &Default::default());
    assert!(e.contains("role") || e.contains("variant"), "{e}");
    assert!(e.len() < 400, "clipped: {e}");
}
