//! `softshadow compare` on EXRs written here: identical inputs give 0, a known perturbation
//! gives the numbers worked out by hand, `--max-mae-lit` sets the exit status, bad inputs
//! are one error line. The command reads files only.

use softshadow::output::write_exr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const W: u32 = 10;
const H: u32 = 10;

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("softshadow-compare-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn compare(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .arg("compare")
        .args(args)
        .output()
        .expect("running softshadow")
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The figure printed on the line that starts with `name`.
fn figure(stdout: &str, name: &str) -> f64 {
    stdout
        .lines()
        .find(|l| l.split_whitespace().next() == Some(name))
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap_or_else(|| panic!("no {name} line in\n{stdout}"))
        .parse()
        .unwrap()
}

/// A 10x10 frame of the plane y = 0 seen from above: row 0 is background, rows 1..=9 are
/// covered; normals +Y except row 9, which faces away from the light (at (0, 10, 0)). The
/// reference visibility is 0.5 in columns 0..5 (shadow) and 1 elsewhere. The spot factor
/// (normal.exr's A) is 1 on every covered pixel.
fn write_aovs(dir: &Path) -> Vec<f32> {
    write_aovs_with(dir, |_, _| 1.0, true)
}

/// `write_aovs` with the spot factor of pixel (x, y) from `spot`, and normal.exr without
/// its A channel when `with_spot` is false.
fn write_aovs_with(dir: &Path, spot: impl Fn(usize, usize) -> f32, with_spot: bool) -> Vec<f32> {
    let n = (W * H) as usize;
    let (mut pos, mut nrm, mut vis) = (vec![vec![0.0; n]; 4], vec![vec![0.0; n]; 4], vec![1.0; n]);
    for y in 0..H as usize {
        for x in 0..W as usize {
            let i = y * W as usize + x;
            if y == 0 {
                continue;
            }
            pos[0][i] = x as f32 * 0.1;
            pos[2][i] = y as f32 * 0.1;
            pos[3][i] = 1.0;
            nrm[1][i] = if y == 9 { -1.0 } else { 1.0 };
            nrm[3][i] = spot(x, y);
            if x < 5 {
                vis[i] = 0.5;
            }
        }
    }
    std::fs::create_dir_all(dir).unwrap();
    write_exr(&dir.join("visibility.exr"), W, H, &["Y"], vec![vis.clone()]).unwrap();
    write_exr(&dir.join("position.exr"), W, H, &["R", "G", "B", "A"], pos).unwrap();
    if !with_spot {
        nrm.pop();
    }
    let names: &[&str] = if with_spot {
        &["R", "G", "B", "A"]
    } else {
        &["R", "G", "B"]
    };
    write_exr(&dir.join("normal.exr"), W, H, names, nrm).unwrap();
    vis
}

fn write_vis(path: &Path, v: Vec<f32>) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    write_exr(path, W, H, &["Y"], vec![v]).unwrap();
}

#[test]
fn identical_inputs_give_zero_and_a_perturbation_gives_the_expected_numbers() {
    let d = scratch("numbers");
    let ours = d.join("ours");
    let v_ref = write_aovs(&ours);
    let port = d.join("port/visibility.exr");
    write_vis(&port, v_ref.clone());
    let png = d.join("diff.png");
    let o = compare(&[
        "--reference",
        ours.to_str().unwrap(),
        "--test",
        port.to_str().unwrap(),
        "--light",
        "0,10,0",
        "--out",
        png.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    for m in ["mae_lit", "p99_lit", "mae_shadow", "off_0.1"] {
        assert_eq!(figure(&out, m), 0.0, "{m}\n{out}");
    }
    // 90 covered pixels, 45 in shadow, 40 of them facing the light (row 9 faces away).
    assert!(
        out.contains(
            "90 covered pixels where light can fall, 45 in the shadow region, 40 of them facing"
        ),
        "{out}"
    );
    let img = image::open(&png).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (W, H));
    assert_eq!(
        img.get_pixel(3, 3).0,
        [0, 0, 0, 255],
        "no difference is black"
    );
    assert_eq!(
        img.get_pixel(3, 0).0,
        [96, 96, 96, 255],
        "background is grey"
    );

    // The port is 0.2 too dark in the shadow of rows 1 and 2 (10 pixels facing the light)
    // and 0.3 too dark in row 9's shadow (5 pixels facing away): mae_lit = 10 * 0.2 / 40,
    // mae_shadow = (10 * 0.2 + 5 * 0.3) / 45, p99_lit = 0.2 (the 40th of 40 values), and 15
    // of the 90 covered pixels are off by more than 0.1.
    let mut v = v_ref.clone();
    for y in [1usize, 2, 9] {
        for x in 0..5 {
            v[y * W as usize + x] -= if y == 9 { 0.3 } else { 0.2 };
        }
    }
    write_vis(&port, v);
    let o = compare(&[
        "--reference",
        ours.to_str().unwrap(),
        "--test",
        d.join("port").to_str().unwrap(),
        "--light",
        "0,10,0",
        "--out",
        png.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    let close = |a: f64, b: f64| (a - b).abs() < 1e-5;
    assert!(close(figure(&out, "mae_lit"), 0.05), "{out}");
    assert!(close(figure(&out, "p99_lit"), 0.2), "{out}");
    assert!(close(figure(&out, "mae_shadow"), 3.5 / 45.0), "{out}");
    assert!(close(figure(&out, "off_0.1"), 15.0 / 90.0), "{out}");
    let img = image::open(&png).unwrap().to_rgba8();
    assert_ne!(
        img.get_pixel(0, 1).0,
        [0, 0, 0, 255],
        "a difference is coloured"
    );
    assert_eq!(img.get_pixel(0, 3).0, [0, 0, 0, 255]);

    // --max-mae-lit: above the threshold fails after printing and writing the image.
    let base = [
        "--reference",
        ours.to_str().unwrap(),
        "--test",
        port.to_str().unwrap(),
        "--light",
        "0,10,0",
        "--out",
        png.to_str().unwrap(),
    ];
    let o = compare(&[&base[..], &["--max-mae-lit", "0.06"]].concat());
    assert!(o.status.success(), "{:?}", text(&o));
    let o = compare(&[&base[..], &["--max-mae-lit", "0.04"]].concat());
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert!(out.contains("mae_lit"), "the figures are printed: {out}");
    assert!(
        err.lines().filter(|l| l.starts_with("error:")).count() == 1
            && err.contains("--max-mae-lit"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_inputs_are_one_clear_error() {
    let d = scratch("bad");
    let ours = d.join("ours");
    let v_ref = write_aovs(&ours);
    let check = |test: &Path, expect: &str| {
        let png = d.join("never.png");
        let o = compare(&[
            "--reference",
            ours.to_str().unwrap(),
            "--test",
            test.to_str().unwrap(),
            "--light",
            "0,10,0",
            "--out",
            png.to_str().unwrap(),
        ]);
        let (out, err) = text(&o);
        assert!(!o.status.success(), "{out}");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(
            err.starts_with("error:") && err.contains(expect),
            "{expect}: {err}"
        );
        assert!(!png.exists(), "nothing written");
    };
    let small = d.join("small.exr");
    write_exr(&small, 5, 5, &["Y"], vec![vec![1.0; 25]]).unwrap();
    check(&small, "5x5 but");
    let rgb = d.join("rgb.exr");
    let n = (W * H) as usize;
    write_exr(&rgb, W, H, &["R", "G", "B"], vec![vec![1.0; n]; 3]).unwrap();
    check(&rgb, "one channel (Y), this one has B, G, R");
    let nan = d.join("nan.exr");
    let mut v = v_ref;
    v[37] = f32::NAN;
    write_exr(&nan, W, H, &["Y"], vec![v]).unwrap();
    check(&nan, "1 non-finite value(s), the first at value 37");
    let junk = d.join("junk.exr");
    std::fs::write(&junk, b"not an exr").unwrap();
    check(&junk, "not a readable EXR");
    check(&d.join("missing.exr"), "no such file");
    let _ = std::fs::remove_dir_all(&d);
}

/// Pixels outside the light's cone (spot factor 0, normal.exr's A) count in no figure: there
/// every technique writes 1 and the reference the true occlusion, and the shading hides
/// both. Without the A channel every covered pixel counts, with one warning.
#[test]
fn only_pixels_where_light_can_fall_are_judged() {
    let d = scratch("cone");
    // Columns 0 and 1 lie outside the cone: the port writes 1 there, the reference 0.5.
    let ours = d.join("ours");
    let v_ref = write_aovs_with(&ours, |x, _| if x < 2 { 0.0 } else { 1.0 }, true);
    let mut v = v_ref.clone();
    for y in 1..H as usize {
        for x in 0..2 {
            v[y * W as usize + x] = 1.0;
        }
    }
    let port = d.join("port/visibility.exr");
    write_vis(&port, v);
    let png = d.join("diff.png");
    let run = |aov: &Path| {
        compare(&[
            "--reference",
            ours.join("visibility.exr").to_str().unwrap(),
            "--test",
            port.to_str().unwrap(),
            "--aov",
            aov.to_str().unwrap(),
            "--light",
            "0,10,0",
            "--out",
            png.to_str().unwrap(),
            "--max-mae-lit",
            "0",
        ])
    };
    let o = run(&ours);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert_eq!(figure(&out, "mae_lit"), 0.0, "{out}");
    assert_eq!(figure(&out, "mae_shadow"), 0.0, "{out}");
    // 9 rows x 8 columns inside the cone; 3 shadow columns of them; row 9 faces away.
    assert!(
        out.contains(
            "72 covered pixels where light can fall, 27 in the shadow region, 24 of them facing"
        ),
        "{out}"
    );
    assert!(err.is_empty(), "{err}");
    // The same frame without the spot factor: all 90 covered pixels count, 16 of the 40
    // facing shadow pixels are off by 0.5, and one warning says why.
    let rgb = d.join("rgb");
    write_aovs_with(&rgb, |_, _| 1.0, false);
    let o = run(&rgb);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert!(
        (figure(&out, "mae_lit") - 16.0 * 0.5 / 40.0).abs() < 1e-6,
        "{out}"
    );
    assert!(
        err.lines()
            .next()
            .is_some_and(|l| l.starts_with("warning:") && l.contains("no A channel")),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A comparison that judges no pixel fails with a warning whatever `--max-mae-lit` says: an
/// all-zero normal.exr faces nothing; a light 1e20 away (whose squared distance overflows
/// f32) still lights the plane below it.
#[test]
fn nothing_to_judge_fails_and_a_far_light_still_has_a_direction() {
    let d = scratch("nothing");
    let ours = d.join("ours");
    write_aovs(&ours);
    let png = d.join("diff.png");
    let run = |light: &str| {
        compare(&[
            "--reference",
            ours.to_str().unwrap(),
            "--test",
            ours.to_str().unwrap(),
            "--light",
            light,
            "--out",
            png.to_str().unwrap(),
            "--max-mae-lit",
            "1",
        ])
    };
    let o = run("0,1e20,0");
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("40 of them facing"), "{out}");
    // Every normal zero: nothing faces the light.
    let n = (W * H) as usize;
    write_exr(
        &ours.join("normal.exr"),
        W,
        H,
        &["R", "G", "B", "A"],
        vec![vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![1.0; n]],
    )
    .unwrap();
    let o = run("0,10,0");
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("warning: no pixel to judge"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

/// `--sun X,Y,Z` is a direction towards a sun, not a point: a sun barely above the plane's
/// horizon along +Y (0,0.1,0) lights every covered up-facing pixel, where a point light at
/// (0,0.1,0) faces only those within 0.49 of the origin (n.l = 0.1 / |to| >= 0.2); a sun
/// below the plane faces only the down-facing row 9. A `--scene` with a sun uses its
/// direction the same way. Bad directions are one error line and write nothing.
#[test]
fn sun_gives_a_direction_for_the_lit_surface_mask() {
    let d = scratch("sun");
    let ours = d.join("ours");
    write_aovs(&ours);
    let png = d.join("diff.png");
    let run = |flag: &str, v: &str| {
        compare(&[
            "--reference",
            ours.to_str().unwrap(),
            "--test",
            ours.to_str().unwrap(),
            flag,
            v,
            "--out",
            png.to_str().unwrap(),
        ])
    };
    let facing = |o: &Output| {
        let (out, err) = text(o);
        assert!(o.status.success(), "{out}{err}");
        let s = out
            .split(" of them facing")
            .next()
            .and_then(|l| l.rsplit(' ').next())
            .unwrap_or_else(|| panic!("no facing count in\n{out}"))
            .to_string();
        s.parse::<usize>().unwrap()
    };
    assert_eq!(facing(&run("--sun", "0,1,0")), 40);
    assert_eq!(facing(&run("--sun", "0,0.1,0")), 40);
    // Shadow pixels (x < 0.5, z in 0.1..=0.8, up-facing) with x^2 + z^2 <= 0.24: by hand,
    // 4 + 4 + 4 + 3 + 2 = 17 of the 40 (columns x = 0 ... 0.4); the loop recounts them.
    let near: usize = (0..5)
        .flat_map(|x| (1..9).map(move |z| (x, z)))
        .filter(|&(x, z)| {
            let (x, z) = (x as f64 * 0.1, z as f64 * 0.1);
            0.1 / (x * x + 0.01 + z * z).sqrt() >= softshadow::eval::metrics::LIT_COS as f64
        })
        .count();
    assert_eq!(near, 17);
    assert_eq!(facing(&run("--light", "0,0.1,0")), near);
    assert_eq!(facing(&run("--sun", "0,-3,0")), 5);
    std::fs::remove_file(&png).unwrap();
    for bad in ["0,0,0", "1,2", "1,nan,0", "a,b,c"] {
        let o = run("--sun", bad);
        let (out, err) = text(&o);
        assert!(!o.status.success(), "--sun {bad}: {out}{err}");
        // One error line (the argument parser adds its `--help` hint, as for --light).
        let errors = err.lines().filter(|l| l.starts_with("error:")).count();
        assert_eq!(errors, 1, "--sun {bad}: {err}");
        assert!(err.starts_with("error:"), "--sun {bad}: {err}");
        assert!(!png.exists(), "--sun {bad} wrote {}", png.display());
    }
    let _ = std::fs::remove_dir_all(&d);
}
