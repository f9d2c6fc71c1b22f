//! The port sheets (`softshadow describe`, docs/port/<technique>.md): each checked-in sheet
//! is what the live pipelines give today, the log a sheet is drawn from says what the
//! recorder did, every technique module's header links its sheet, and a bad technique name
//! is one clear line.

mod common;

use common::Gpu;
use softshadow::render::describe::{port_sheet, sheet_settings, DEFAULT_SCENE, REFRESH_COMMAND};
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::technique::{names, TECHNIQUES};
use softshadow::vk::describe::{BarrierInfo, Event, PassRef};
use softshadow::vk::ImageLayout;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Pass `pass` of logged frame `frame`.
fn at(frame: u32, pass: &str) -> PassRef {
    PassRef {
        frame,
        pass: Some(pass.into()),
    }
}

fn sheet(gpu: &Gpu, technique: &str) -> String {
    let scene = Scene::load(DEFAULT_SCENE).unwrap();
    port_sheet(&gpu.ctx, scene, DEFAULT_SCENE, technique, sheet_settings())
        .unwrap_or_else(|e| panic!("describing {technique}: {e:#}"))
}

/// Regenerates every sheet and compares it with docs/port/<technique>.md: a change to a
/// pipeline, a pass or a barrier that the checked-in sheet does not show fails here.
#[test]
fn every_checked_in_sheet_is_what_the_pipelines_give() {
    let gpu = Gpu::new();
    let dir = root().join("docs/port");
    let mut stale = Vec::new();
    for t in TECHNIQUES {
        let path = dir.join(format!("{}.md", t.name));
        let now = sheet(&gpu, t.name);
        match std::fs::read_to_string(&path) {
            Ok(old) if old == now => {}
            Ok(old) => {
                let line = old
                    .lines()
                    .zip(now.lines())
                    .position(|(a, b)| a != b)
                    .map_or(old.lines().count().min(now.lines().count()), |i| i)
                    + 1;
                stale.push(format!("docs/port/{}.md differs from line {line}", t.name));
            }
            Err(e) => stale.push(format!("docs/port/{}.md: {e}", t.name)),
        }
    }
    // No sheet of a technique the registry no longer has.
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        let Some(technique) = name.strip_suffix(".md") else {
            continue;
        };
        if !names().contains(&technique) {
            stale.push(format!("docs/port/{name} names no technique"));
        }
    }
    assert!(
        stale.is_empty(),
        "stale port sheets (refresh with `{REFRESH_COMMAND}` and read the diff):\n{}",
        stale.join("\n")
    );
}

/// Two renderers of one technique give the same sheet, and it holds no handle, pointer or
/// host path: what makes a checked-in sheet comparable at all.
#[test]
fn a_sheet_is_the_same_from_run_to_run_and_names_no_host_detail() {
    let gpu = Gpu::new();
    // ssm: graphics and compute passes, buffers and images, sets rebound.
    let a = sheet(&gpu, "ssm");
    let b = sheet(&gpu, "ssm");
    assert_eq!(a, b);
    let root = root();
    let here = root.to_string_lossy();
    for bad in ["0x", here.as_ref(), " ms", "Handle", "null"] {
        assert!(!a.contains(bad), "the sheet holds `{bad}`:\n{a}");
    }
}

/// The sheet's passes are the frame's: the same names in the same order as the timings of
/// a frame rendered without the log (a second path to the pass list).
#[test]
fn the_sheet_lists_the_passes_the_timings_report() {
    let gpu = Gpu::new();
    for technique in ["hard", "smoothies-centred", "ssm2", "reference"] {
        let mut r = Renderer::new(
            &gpu.ctx,
            Scene::load(DEFAULT_SCENE).unwrap(),
            technique,
            sheet_settings(),
        )
        .unwrap();
        let timed: Vec<String> = r
            .render()
            .unwrap()
            .passes
            .iter()
            .map(|p| p.name.clone())
            .collect();
        let text = sheet(&gpu, technique);
        let listed: Vec<String> = text
            .lines()
            .filter_map(|l| l.strip_prefix("## "))
            .filter_map(|l| l.split_once(". `"))
            .map(|(_, rest)| rest.trim_end_matches('`').to_string())
            .collect();
        assert_eq!(listed, timed, "{technique}");
    }
}

/// The log a sheet is drawn from: pcss's final pass samples the shadow map, so the recorder
/// moves it from the attachment layout to the sampled one, after the shadow-map pass of the
/// same frame; the next frame's clear of the map waits for that read (a write after a read:
/// no access to make visible) and lets the old contents go.
#[test]
fn the_log_holds_the_barriers_the_recorder_derived() {
    let gpu = Gpu::new();
    let mut r = Renderer::new(
        &gpu.ctx,
        Scene::load(DEFAULT_SCENE).unwrap(),
        "pcss",
        sheet_settings(),
    )
    .unwrap();
    let log = r.log_frames(2).unwrap();
    assert_eq!(log.frames.len(), 2);
    let frame = &log.frames[1];
    let map = "image 'pcss/shadow_map shadow map'";
    // Barriers of `map` with the pass they were recorded in.
    let mut pass = None;
    let mut seen = Vec::new();
    for e in frame {
        match e {
            Event::PassBegin(p) => pass = Some(p.clone()),
            Event::Barriers(bs) => {
                for b in bs.iter().filter(|b| b.resource == map) {
                    seen.push((pass.clone().unwrap(), b.clone()));
                }
            }
            _ => {}
        }
    }
    assert_eq!(seen.len(), 2, "{seen:#?}");
    let summary = |(pass, b): &(String, BarrierInfo)| (pass.clone(), b.layouts, b.after.clone());
    use ImageLayout as L;
    assert_eq!(
        summary(&seen[0]),
        (
            "pcss/shadow_map".to_string(),
            Some((L::UNDEFINED, L::COLOR_ATTACHMENT_OPTIMAL)),
            vec![at(0, "pcss/final")]
        )
    );
    assert!(seen[0].1.src_access.is_empty());
    assert_eq!(
        summary(&seen[1]),
        (
            "pcss/final".to_string(),
            Some((L::COLOR_ATTACHMENT_OPTIMAL, L::SHADER_READ_ONLY_OPTIMAL)),
            vec![at(1, "pcss/shadow_map")]
        )
    );
}

/// `//! Port sheet: docs/port/<name>.md` in the header of the module that registers each
/// row, and every sheet a header links exists.
#[test]
fn every_technique_module_header_links_its_sheet() {
    let dir = root().join("src/technique");
    let mut linked = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        // Modules only: src/technique/speed/ is a folder of them, none a technique's.
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for line in text.lines().take_while(|l| l.starts_with("//!")) {
            let Some(rest) = line.strip_prefix("//! Port sheet") else {
                continue;
            };
            for link in rest.split_whitespace().filter(|w| w.contains("docs/port/")) {
                let link = link.trim_matches(|c: char| c == ',' || c == '.' || c == '`');
                assert!(
                    root().join(link).is_file(),
                    "{} links {link}, which does not exist",
                    path.display()
                );
                let name = Path::new(link).file_stem().unwrap().to_string_lossy();
                linked.push((name.into_owned(), path.clone()));
            }
        }
    }
    for t in TECHNIQUES {
        let Some((_, file)) = linked.iter().find(|(n, _)| n == t.name) else {
            panic!("no technique module header links docs/port/{}.md", t.name);
        };
        let text = std::fs::read_to_string(file).unwrap();
        assert!(
            text.contains(&format!("name: \"{}\"", t.name)),
            "{} links docs/port/{}.md but does not register that row",
            file.display(),
            t.name
        );
    }
}

/// A technique the registry does not have: one `error:` line naming every known one, a
/// non-zero exit, no sheet.
#[test]
fn an_unknown_technique_is_one_line_naming_the_known_ones() {
    let out = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(["describe", "--technique", "pcsss"])
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    for name in names() {
        assert!(lines[0].contains(name), "{name} missing from: {stderr}");
    }
    // A removed technique: one line saying it was removed and why, for every command.
    for args in [
        &["describe", "--technique", "pcss-fast"][..],
        &[
            "render",
            "--technique",
            "pcss-walk",
            "--out",
            "never-written.png",
        ][..],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_softshadow"))
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with("error: "), "{stderr}");
        assert!(stderr.contains("was removed: "), "{stderr}");
        assert!(stderr.contains("use pcss"), "{stderr}");
        assert!(!std::path::Path::new("never-written.png").exists());
    }
    // --all needs a folder to write into.
    let out = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(["describe", "--all"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.starts_with("error: "), "{stderr}");
}
