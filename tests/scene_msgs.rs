//! Every bad-input error is exactly one line naming the file; `--nocapture` prints them
//! as users see them.
use softshadow::scene::Scene;
#[test]
fn bad_input_errors_are_single_lines() {
    let d = std::env::temp_dir().join(format!("ssmsg{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let cases = [
        (
            "k.toml",
            "[[object]]\nprimitive = \"box\"\n\n[light]\nposition = [0, 5, 0]\nradus = 0.2\n",
        ),
        (
            "r.toml",
            "[[object]]\nprimitive = \"box\"\nrole = \"blocker\"\n",
        ),
        (
            "s.toml",
            "[[object]]\nprimitive = \"box\"\nscale = [1, 2]\n",
        ),
        ("n.obj", "v 0 0 0\nv 1 0 0\nv 0 NaN 1\nf 1 2 3\n"),
        ("i.obj", "v 0 0 0\nv 1 0 0\nv 0 1 1\nf 1 2 9\n"),
        ("e.obj", "# nothing\n"),
        ("g.obj", "v 0 0 0\nvt x\nf 1 2 3\n"),
    ];
    for (f, t) in cases {
        let p = d.join(f);
        std::fs::write(&p, t).unwrap();
        let e = format!("{:#}", Scene::load(p.to_str().unwrap()).unwrap_err());
        println!("{e}");
        assert!(e.contains(f) && !e.contains('\n'), "{e}");
    }
    // A name that is neither a built-in nor a file: one line naming it and the built-ins.
    let e = format!("{:#}", Scene::load("nope").unwrap_err());
    println!("{e}");
    assert!(
        e.contains("'nope'") && e.contains("cylinder") && !e.contains('\n'),
        "{e}"
    );
    // A missing file: one line naming it.
    let e = format!("{:#}", Scene::load("missing.obj").unwrap_err());
    println!("{e}");
    assert!(e.contains("missing.obj") && !e.contains('\n'), "{e}");
    std::fs::remove_dir_all(&d).ok();
}
