//! Port sheets: `softshadow describe --technique T` and docs/port/<technique>.md.
//!
//! A sheet is drawn from the live objects, not from prose: the technique is created on the
//! device for a scene, two frames are rendered with the recorder's log on
//! (`Renderer::log_frames`), and the second frame's log is written out pass by pass: the
//! barriers the recorder derived in front of each command, each rendering scope's
//! attachments, each pipeline bound (its shaders, vertex input, rasterizer, depth and
//! blend state, push constants, as `Pipeline` kept them from its create-info), the
//! descriptor sets bound with it and which stages use each binding (from the SPIR-V), and
//! the draws and dispatches. The second frame is the one a frame loop repeats: its barriers
//! wait for the first frame's passes where a resource outlives the frame.
//!
//! The frame is recorded with `Settings::plain` (the technique without the speed layer) and
//! silhouettes found on the CPU, so that the sheet is the same on every device; it holds no
//! handle, pointer, time or host path, so it is the same on every run (tests/port_sheets.rs).

use super::Renderer;
use crate::scene::Scene;
use crate::settings::{Settings, SilhouettePath};
use crate::technique;
use crate::vk::describe::{
    AttachmentInfo, BarrierInfo, BlendInfo, Event, PassRef, PipelineInfo, SetInfo,
};
use crate::vk::{AccessFlags2, BindingKind, Context, PipelineStageFlags2};
use anyhow::{Context as _, Result};
use std::sync::Arc;

/// The scene a sheet is recorded on unless another is named.
pub const DEFAULT_SCENE: &str = "cylinder";

/// What docs/port/ says refreshes every sheet.
pub const REFRESH_COMMAND: &str = "cargo run -- describe --all --out docs/port";

/// The settings a sheet is recorded with: the defaults, plain, silhouettes on the CPU.
pub fn sheet_settings() -> Settings {
    Settings {
        plain: true,
        silhouettes: SilhouettePath::Cpu,
        ..Settings::default()
    }
}

/// The port sheet of `technique` on `scene` (named `scene_label` on the sheet), as Markdown.
pub fn port_sheet(
    ctx: &Context,
    scene: Scene,
    scene_label: &str,
    technique: &str,
    settings: Settings,
) -> Result<String> {
    let info = technique::find(technique)?;
    let mut r = Renderer::new(ctx, scene, technique, settings.clone())
        .with_context(|| format!("creating {technique}"))?;
    let log = r
        .log_frames(2)
        .with_context(|| format!("recording {technique}"))?;
    let events = log.frames.last().cloned().unwrap_or_default();
    let mut sheet = Sheet {
        out: String::new(),
        frame: log.frames.len().saturating_sub(1) as u32,
    };
    sheet.header(info, r.technique_type(), scene_label, &r.settings, &events);
    sheet.passes(&events);
    Ok(sheet.out)
}

struct Sheet {
    out: String,
    /// The logged frame the sheet shows (the last).
    frame: u32,
}

/// The events of one pass (or of commands outside any pass), in order.
struct PassEvents<'a> {
    name: Option<&'a str>,
    events: &'a [Event],
}

/// Splits a frame's events at its passes; CPU work and skipped passes are their own items.
fn split_passes(events: &[Event]) -> Vec<PassEvents<'_>> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < events.len() {
        match &events[i] {
            Event::PassBegin(name) => {
                let end = events[i..]
                    .iter()
                    .position(|e| matches!(e, Event::PassEnd(_)))
                    .map_or(events.len(), |p| i + p);
                out.push(PassEvents {
                    name: Some(name),
                    events: &events[i + 1..end],
                });
                i = end + 1;
            }
            _ => {
                let end = events[i..]
                    .iter()
                    .position(|e| matches!(e, Event::PassBegin(_)))
                    .map_or(events.len(), |p| i + p);
                out.push(PassEvents {
                    name: None,
                    events: &events[i..end],
                });
                i = end;
            }
        }
    }
    out
}

/// ash prints flags as `A | B`; a table cell takes `A, B` (a bare `|` splits it).
fn flags<T: std::fmt::Debug>(f: T) -> String {
    let s = format!("{f:?}").replace(" | ", ", ");
    if s.is_empty() || s == "0" {
        "NONE".into()
    } else {
        s
    }
}

fn stages_and_access(stage: PipelineStageFlags2, access: AccessFlags2) -> String {
    format!("{} / {}", flags(stage), flags(access))
}

/// The last three cells of a barrier's row: source, destination, layout.
fn scopes(b: &BarrierInfo) -> String {
    let layout = match b.layouts {
        Some((old, new)) if old == new => format!("{old:?}"),
        Some((old, new)) => format!("{old:?} → {new:?}"),
        None => "(buffer)".into(),
    };
    format!(
        "{} | {} | {layout}",
        stages_and_access(b.src_stage, b.src_access),
        stages_and_access(b.dst_stage, b.dst_access)
    )
}

fn kind_text(kind: BindingKind) -> &'static str {
    match kind {
        BindingKind::UniformBuffer => "uniform buffer",
        BindingKind::StorageBuffer => "storage buffer",
        BindingKind::SampledImage => "combined image sampler",
        BindingKind::StorageImage => "storage image",
    }
}

/// The stage names a `UseInfo` or barrier lists, short: `vertex, fragment`.
fn shader_stages(s: PipelineStageFlags2) -> String {
    let mut names = Vec::new();
    for (bit, name) in [
        (PipelineStageFlags2::VERTEX_SHADER, "vertex"),
        (PipelineStageFlags2::FRAGMENT_SHADER, "fragment"),
        (PipelineStageFlags2::COMPUTE_SHADER, "compute"),
    ] {
        if s.contains(bit) {
            names.push(name);
        }
    }
    names.join(", ")
}

fn write_mask(b: &BlendInfo) -> String {
    use crate::vk::describe::ColorComponentFlags as C;
    let mut s = String::new();
    for (bit, c) in [(C::R, 'R'), (C::G, 'G'), (C::B, 'B'), (C::A, 'A')] {
        if b.write_mask.contains(bit) {
            s.push(c);
        }
    }
    if s.is_empty() {
        "none".into()
    } else {
        s
    }
}

impl Sheet {
    fn line(&mut self, s: &str) {
        self.out.push_str(s);
        self.out.push('\n');
    }

    /// A paragraph: `s` and a blank line.
    fn para(&mut self, s: &str) {
        self.line(s);
        self.line("");
    }

    fn pass_ref(&self, r: &PassRef) -> String {
        let name = match &r.pass {
            Some(p) => format!("`{p}`"),
            None => "commands outside any pass".into(),
        };
        match r.frame {
            f if f == self.frame => name,
            f if f + 1 == self.frame => format!("{name} of the previous frame"),
            _ => format!("{name} of an earlier frame"),
        }
    }

    fn header(
        &mut self,
        info: &technique::TechniqueInfo,
        type_name: &str,
        scene: &str,
        s: &Settings,
        events: &[Event],
    ) {
        let name = info.name;
        self.para(&format!("# Port sheet: `{name}`"));
        self.line(&format!(
            "Generated by `softshadow describe --technique {name}` from the live pipeline \
             objects and one recorded frame; do not edit. `{REFRESH_COMMAND}` rewrites every \
             sheet, and `cargo test --test port_sheets` fails when one is stale."
        ));
        self.line("");
        self.para(&format!("{}.", info.summary));
        let mut made_in: Vec<&str> = Vec::new();
        let mut shaders: Vec<String> = Vec::new();
        for e in events {
            match e {
                Event::BindPipeline(p) => {
                    made_in.push(p.made_in);
                    for st in &p.stages {
                        shaders.push(st.source.clone().unwrap_or_else(|| "(unknown)".into()));
                    }
                }
                Event::BindSets(sets) => made_in.extend(sets.iter().map(|s| s.made_in)),
                _ => {}
            }
        }
        made_in.sort();
        made_in.dedup();
        shaders.sort();
        shaders.dedup();
        let quoted = |v: &[&str]| {
            v.iter()
                .map(|m| format!("`{m}`"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        self.line(&format!(
            "- **Construction:** `{type_name}`, created by the registry row `{name}` \
             (`softshadow::technique::TECHNIQUES`); the pipelines and descriptor sets below \
             are made in {}.",
            quoted(&made_in)
        ));
        let shader_refs: Vec<&str> = shaders.iter().map(String::as_str).collect();
        self.line(&format!("- **Shaders:** {}.", quoted(&shader_refs)));
        self.line(&format!(
            "- **Recorded:** scene `{scene}`, image {}x{}, light-space buffers {}x{} \
             (occluder map {}x{} where used), `--plain` (the technique without the speed \
             layer), silhouettes on the CPU. The second frame of two: its barriers are a \
             frame loop's, waiting for the previous frame where a resource outlives it.",
            s.width, s.height, s.shadow_res, s.shadow_res, s.occluder_res, s.occluder_res
        ));
        self.line(
            "- **Not shown:** the untimed AOV and counting passes (`T/aov`, `T/count`), which \
             draw the final pass again with the `-DAOV` and `-DCOUNT` builds of its fragment \
             shader into more attachments.",
        );
        self.line("");
        self.para("## Passes, in order");
        self.line("| # | pass | pipelines | writes | reads |");
        self.line("|---|---|---|---|---|");
        let mut n = 0;
        for p in split_passes(events) {
            match p.name {
                Some(name) => {
                    n += 1;
                    let o = Overview::of(p.events);
                    let cell = |v: &[String]| match v.is_empty() {
                        true => "-".to_string(),
                        false => v.join("; "),
                    };
                    self.line(&format!(
                        "| {n} | `{name}` | {} | {} | {} |",
                        cell(&o.pipelines),
                        cell(&o.writes),
                        cell(&o.reads)
                    ));
                }
                None => {
                    for e in p.events {
                        match e {
                            Event::Cpu(c) => self.line(&format!("| | CPU work `{c}` | | | |")),
                            Event::Skipped(s, why) => {
                                self.line(&format!("| | `{s}` skipped ({why}) | | | |"))
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        self.line("");
    }

    fn passes(&mut self, events: &[Event]) {
        let passes = split_passes(events);
        let mut n = 0;
        for (i, p) in passes.iter().enumerate() {
            let title = match p.name {
                Some(name) => {
                    n += 1;
                    format!("## {n}. `{name}`")
                }
                None => {
                    if !p.events.iter().any(|e| {
                        !matches!(e, Event::Cpu(_) | Event::Skipped(..) | Event::PassEnd(_))
                    }) {
                        continue;
                    }
                    "## Commands outside any pass".to_string()
                }
            };
            self.para(&title);
            self.commands(p.events);
            if let Some(name) = p.name {
                self.waiters(name, &passes, i);
            }
        }
    }

    fn barriers(&mut self, title: &str, barriers: &[BarrierInfo]) {
        self.para(&format!("{title}:"));
        self.line("| resource | waits for | source stages / access | destination stages / access | layout |");
        self.line("|---|---|---|---|---|");
        for b in barriers {
            let after = match b.after.is_empty() {
                true => "nothing earlier".to_string(),
                false => b
                    .after
                    .iter()
                    .map(|a| self.pass_ref(a))
                    .collect::<Vec<_>>()
                    .join(", "),
            };
            self.line(&format!("| {} | {after} | {} |", b.resource, scopes(b)));
        }
        self.line("");
    }

    fn attachments(&mut self, colors: &[AttachmentInfo], depth: &Option<AttachmentInfo>) {
        self.line("| attachment | image | format | load op | clear value | store op |");
        self.line("|---|---|---|---|---|---|");
        let rows = colors
            .iter()
            .enumerate()
            .map(|(i, a)| (format!("colour {i}"), a))
            .chain(depth.iter().map(|a| ("depth".to_string(), a)));
        for (what, a) in rows {
            let (load, clear) = match &a.clear {
                Some(c) => ("CLEAR", c.as_str()),
                None => ("LOAD", "-"),
            };
            let store = if a.store { "STORE" } else { "DONT_CARE" };
            self.line(&format!(
                "| {what} | '{}' | {:?} | {load} | {clear} | {store} |",
                a.image, a.format
            ));
        }
        self.line("");
    }

    fn pipeline(&mut self, p: &PipelineInfo, sets: &[Arc<SetInfo>]) {
        let kind = if p.compute { "compute" } else { "graphics" };
        self.line(&format!(
            "Pipeline `{}` ({kind}, made in `{}`):",
            p.name, p.made_in
        ));
        self.line("");
        let stages: Vec<String> = p
            .stages
            .iter()
            .map(|s| {
                let src = s.source.as_deref().unwrap_or("(SPIR-V not from glsl/)");
                format!("{} `{src}`", s.stage)
            })
            .collect();
        self.line(&format!("- shaders: {}", stages.join(", ")));
        if !p.compute {
            let input = match p.vertex_stride {
                0 => "none (the vertex shader makes or pulls its vertices)".to_string(),
                stride => {
                    let attrs: Vec<String> = p
                        .attributes
                        .iter()
                        .map(|(loc, fmt, off)| format!("location {loc} {fmt:?} at {off}"))
                        .collect();
                    format!("binding 0, {stride} bytes per vertex: {}", attrs.join("; "))
                }
            };
            self.line(&format!("- vertex input: {input}"));
            self.line(&format!(
                "- topology {:?}, cull {}, front face {:?}",
                p.topology,
                flags(p.cull),
                p.front_face
            ));
            let depth = match &p.depth {
                Some(d) => format!(
                    "{:?}, test {}, write {}, compare {:?}",
                    d.format,
                    if d.test { "on" } else { "off" },
                    if d.write { "on" } else { "off" },
                    d.compare
                ),
                None => "no depth attachment".into(),
            };
            self.line(&format!("- depth: {depth}"));
            if let Some(op) = p.logic_op {
                self.line(&format!("- logic op {op:?} on every colour attachment"));
            }
        }
        let push = match p.push_constant_bytes {
            0 => "none".to_string(),
            n => format!("{n} bytes at offset 0, every stage"),
        };
        self.para(&format!("- push constants: {push}"));
        if !p.colors.is_empty() {
            self.line("| colour | format | blend | colour op | alpha op | src factor | dst factor | write mask |");
            self.line("|---|---|---|---|---|---|---|---|");
            for (i, b) in p.colors.iter().enumerate() {
                let row = if b.enable {
                    format!(
                        "on | {:?} | {:?} | {:?} | {:?}",
                        b.color_op, b.alpha_op, b.src_factor, b.dst_factor
                    )
                } else {
                    "off | - | - | - | -".into()
                };
                self.line(&format!(
                    "| {i} | {:?} | {row} | {} |",
                    b.format,
                    write_mask(b)
                ));
            }
            self.line("");
        }
        self.sets(p, sets);
    }

    /// The descriptor sets bound with `p`, binding by binding, with the stages of `p` that
    /// use each.
    fn sets(&mut self, p: &PipelineInfo, sets: &[Arc<SetInfo>]) {
        if sets.is_empty() {
            self.para("No descriptor set.");
            return;
        }
        self.line("| set | binding | name | kind | bound | used by |");
        self.line("|---|---|---|---|---|---|");
        for (si, set) in sets.iter().enumerate() {
            for b in &set.bindings {
                let used = p
                    .uses
                    .iter()
                    .find(|u| u.set == si as u32 && u.binding == b.binding)
                    .map(|u| {
                        let rw = if u.writes { "read, write" } else { "read" };
                        format!("{} ({rw})", shader_stages(u.stages))
                    })
                    .unwrap_or_else(|| "unused".into());
                let bound = match b.detail.is_empty() {
                    true => b.resource.clone(),
                    false => format!("{} {}", b.resource, b.detail),
                };
                self.line(&format!(
                    "| {si} `{}` | {} | `{}` | {} | {bound} | {used} |",
                    set.name,
                    b.binding,
                    b.name,
                    kind_text(b.kind)
                ));
            }
        }
        self.line("");
    }

    /// The commands of one pass, in order; draws after one pipeline bind are summed up.
    fn commands(&mut self, events: &[Event]) {
        // A pipeline bound and not yet shown: it is shown with the sets bound after it, or
        // with none at the next other command.
        let mut pending: Option<Arc<PipelineInfo>> = None;
        let mut shown: Vec<(Arc<PipelineInfo>, Vec<Arc<SetInfo>>)> = Vec::new();
        let mut draws = Draws::default();
        for e in events {
            if !matches!(e, Event::BindSets(_)) {
                if let Some(p) = pending.take() {
                    self.bound(&p, &[], &mut shown);
                }
            }
            match e {
                Event::BindPipeline(p) => {
                    self.draws(&mut draws);
                    pending = Some(p.clone());
                }
                Event::BindSets(sets) => {
                    if let Some(p) = pending.take() {
                        self.bound(&p, sets, &mut shown);
                    }
                }
                Event::Barriers(b) => {
                    self.draws(&mut draws);
                    self.barriers("Barriers the recorder puts in front", b);
                }
                Event::Rendering {
                    colors,
                    depth,
                    extent,
                    whole,
                } => {
                    let area = if *whole {
                        "the whole target"
                    } else {
                        "part of the target"
                    };
                    self.line(&format!(
                        "Rendering scope, {}x{}, {area}:",
                        extent.0, extent.1
                    ));
                    self.line("");
                    self.attachments(colors, depth);
                }
                Event::EndRendering => {
                    self.draws(&mut draws);
                    self.para("End of the rendering scope.");
                }
                Event::Push(n) => draws.push = Some(*n),
                Event::VertexBuffer(b) => add_once(&mut draws.vertex, b),
                Event::IndexBuffer(b) => add_once(&mut draws.index, b),
                Event::Scissor => draws.scissors += 1,
                Event::Draw => draws.direct += 1,
                Event::DrawIndexed => draws.indexed += 1,
                Event::DrawIndirect(b) => {
                    draws.indirect += 1;
                    add_once(&mut draws.args, b);
                }
                Event::Dispatch([x, y, z]) => {
                    self.dispatch(&mut draws, &format!("{x}x{y}x{z} workgroups"));
                }
                Event::DispatchIndirect(b) => {
                    self.dispatch(
                        &mut draws,
                        &format!("indirect: workgroups from buffer '{b}'"),
                    );
                }
                Event::Fill(b) => {
                    self.para(&format!("Fill buffer '{b}'."));
                }
                Event::Copy(src, dst) => {
                    self.para(&format!("Copy '{src}' to '{dst}'."));
                }
                Event::HostRead(b) => {
                    self.para(&format!("Host read of buffer '{b}'."));
                }
                Event::Cpu(c) => {
                    self.para(&format!("CPU work `{c}`."));
                }
                Event::Skipped(s, why) => {
                    self.para(&format!("`{s}` skipped ({why})."));
                }
                Event::PassBegin(_) | Event::PassEnd(_) => {}
            }
        }
        self.draws(&mut draws);
    }

    /// A pipeline bound with `sets`: in full the first time in a pass, then only what
    /// differs.
    fn bound(
        &mut self,
        p: &Arc<PipelineInfo>,
        sets: &[Arc<SetInfo>],
        shown: &mut Vec<(Arc<PipelineInfo>, Vec<Arc<SetInfo>>)>,
    ) {
        let same_sets = |s: &[Arc<SetInfo>]| {
            s.len() == sets.len() && s.iter().zip(sets).all(|(a, b)| **a == **b)
        };
        if shown.iter().any(|(q, s)| **q == **p && same_sets(s)) {
            self.para(&format!("Pipeline `{}` again, with the same sets.", p.name));
        } else if shown.iter().any(|(q, _)| **q == **p) {
            self.para(&format!("Pipeline `{}` again, with these sets:", p.name));
            self.sets(p, sets);
        } else {
            self.pipeline(p, sets);
        }
        shown.push((p.clone(), sets.to_vec()));
    }

    /// A dispatch's line: its workgroups (`groups`) and the push constants set before it.
    fn dispatch(&mut self, draws: &mut Draws, groups: &str) {
        let push = match draws.push.take() {
            Some(n) => format!(", {n} bytes of push constants"),
            None => String::new(),
        };
        self.draws(draws);
        self.para(&format!("Dispatch {groups}{push}."));
    }

    fn draws(&mut self, d: &mut Draws) {
        let mut parts = Vec::new();
        let count = |n: usize, what: &str| match n {
            1 => format!("1 {what}"),
            n => format!("{n} {what}s"),
        };
        if d.direct > 0 {
            parts.push(count(d.direct, "draw"));
        }
        if d.indexed > 0 {
            parts.push(count(d.indexed, "indexed draw"));
        }
        if d.indirect > 0 {
            parts.push(format!(
                "{} (arguments in {})",
                count(d.indirect, "indirect draw"),
                quote_list(&d.args)
            ));
        }
        if parts.is_empty() {
            *d = Draws::default();
            return;
        }
        let mut s = parts.join(", ");
        if !d.vertex.is_empty() {
            s += &format!("; vertex buffer {}", quote_list(&d.vertex));
        }
        if !d.index.is_empty() {
            s += &format!("; index buffer {} (UINT32)", quote_list(&d.index));
        }
        if let Some(n) = d.push {
            s += &format!("; {n} bytes of push constants per draw");
        }
        if d.scissors > 0 {
            s += "; scissored";
        }
        self.para(&format!("Draws: {s}."));
        *d = Draws::default();
    }

    /// The barriers of later passes (and of the next frame) that wait for pass `name`.
    fn waiters(&mut self, name: &str, passes: &[PassEvents<'_>], at: usize) {
        let this = |frame: u32| PassRef {
            frame,
            pass: Some(name.to_string()),
        };
        let mut rows = Vec::new();
        let mut scan = |range: &[PassEvents<'_>], who: PassRef, next_frame: bool| {
            for p in range {
                for e in p.events {
                    let Event::Barriers(bs) = e else { continue };
                    for b in bs.iter().filter(|b| b.after.contains(&who)) {
                        let place = match (p.name, next_frame) {
                            (Some(n), false) => format!("`{n}`"),
                            (Some(n), true) => format!("`{n}` of the next frame"),
                            (None, false) => "commands outside any pass".into(),
                            (None, true) => "commands outside any pass, next frame".into(),
                        };
                        rows.push((place, b.clone()));
                    }
                }
            }
        };
        scan(&passes[at + 1..], this(self.frame), false);
        if self.frame > 0 {
            scan(passes, this(self.frame - 1), true);
        }
        if rows.is_empty() {
            self.para("No later barrier waits for this pass.");
            return;
        }
        self.para("Barriers that wait for this pass, later:");
        self.line(
            "| in front of | resource | source stages / access | destination stages / access | layout |",
        );
        self.line("|---|---|---|---|---|");
        for (place, b) in rows {
            self.line(&format!("| {place} | {} | {} |", b.resource, scopes(&b)));
        }
        self.line("");
    }
}

fn add_once(v: &mut Vec<String>, s: &str) {
    if !v.iter().any(|x| x == s) {
        v.push(s.to_string());
    }
}

fn quote_list(v: &[String]) -> String {
    v.iter()
        .map(|s| format!("'{s}'"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Draws since the last pipeline bind, summed up for one line.
#[derive(Default)]
struct Draws {
    direct: usize,
    indexed: usize,
    indirect: usize,
    args: Vec<String>,
    vertex: Vec<String>,
    index: Vec<String>,
    push: Option<usize>,
    scissors: usize,
}

/// One line of the pass table: the pipelines a pass binds, what it writes (attachments
/// with their load op and blend, storage it writes, fills and copies) and what it reads.
#[derive(Default)]
struct Overview {
    pipelines: Vec<String>,
    writes: Vec<String>,
    reads: Vec<String>,
}

impl Overview {
    fn of(events: &[Event]) -> Self {
        let mut o = Overview::default();
        // The open scope's attachments, each with the blends of the pipelines drawn into it.
        let mut scope: Vec<(&AttachmentInfo, bool, Vec<String>)> = Vec::new();
        let mut pipeline: Option<&PipelineInfo> = None;
        for e in events {
            match e {
                Event::Rendering { colors, depth, .. } => {
                    scope = colors.iter().map(|a| (a, false, Vec::new())).collect();
                    scope.extend(depth.iter().map(|a| (a, true, Vec::new())));
                }
                Event::BindPipeline(p) => {
                    add_once(&mut o.pipelines, &format!("`{}`", p.name));
                    pipeline = Some(p);
                    let mut colour = 0;
                    for (_, is_depth, blends) in scope.iter_mut() {
                        let blend = if *is_depth {
                            p.depth.map(|d| match (d.test, d.write) {
                                (true, true) => format!("test {:?}, write", d.compare),
                                (true, false) => format!("test {:?}", d.compare),
                                (false, true) => "write".to_string(),
                                (false, false) => "unused".to_string(),
                            })
                        } else {
                            colour += 1;
                            p.colors
                                .get(colour - 1)
                                .map(|b| match (b.enable, p.logic_op) {
                                    (true, _) => format!("blend {:?}", b.color_op),
                                    (false, Some(op)) => format!("logic op {op:?}"),
                                    (false, None) => "no blend".to_string(),
                                })
                        };
                        if let Some(b) = blend {
                            add_once(blends, &b);
                        }
                    }
                }
                Event::BindSets(sets) => {
                    let Some(p) = pipeline else { continue };
                    for u in &p.uses {
                        let Some(b) = sets
                            .get(u.set as usize)
                            .and_then(|s| s.bindings.get(u.binding as usize))
                        else {
                            continue;
                        };
                        match u.writes {
                            true => add_once(&mut o.writes, &b.resource),
                            false => add_once(&mut o.reads, &b.resource),
                        }
                    }
                }
                Event::EndRendering => {
                    for (a, is_depth, blends) in scope.drain(..) {
                        let load = match &a.clear {
                            Some(c) => format!("clear {c}"),
                            None => "load".into(),
                        };
                        let what = if is_depth { "depth " } else { "" };
                        let mut text = format!("{what}'{}' {:?} ({load}", a.image, a.format);
                        for b in blends {
                            text += &format!(", {b}");
                        }
                        text.push(')');
                        o.writes.push(text);
                    }
                }
                Event::Fill(b) => add_once(&mut o.writes, &format!("buffer '{b}' (fill)")),
                Event::Copy(src, dst) => {
                    add_once(&mut o.reads, &format!("'{src}' (copy)"));
                    add_once(&mut o.writes, &format!("'{dst}' (copy)"));
                }
                Event::DrawIndirect(b) | Event::DispatchIndirect(b) => {
                    add_once(&mut o.reads, &format!("buffer '{b}' (indirect arguments)"))
                }
                _ => {}
            }
        }
        o
    }
}
