//! Silhouette benchmarks: adjacency build once per mesh, then per light `extract` (parallel
//! and serial) and `build_smoothies`, on procedural meshes built here (a UV sphere of ~10k
//! and ~50k triangles, a torus of ~50k; a ~1M-triangle sphere for the adjacency build) so
//! the bench does not depend on the scene module's primitives. Sample sizes are small so
//! the whole bench finishes in well under a minute.
//!
//! The `scenes` group runs the same CPU work on every built-in scene (`Scene::load`), all
//! casters of the scene for its light (fitted as the renderer fits it, smoothie width
//! calibrated from the scene's radius; one adjacency per distinct mesh, shared by the
//! objects that instance it, from `caster_adjacency` as the techniques build it):
//! `extract` (rayon), `extract_serial`, `build_smoothies`, and `total` (extract +
//! smoothies, what one frame of `smoothies` does per light) on all cores and on one core
//! (a one-thread rayon pool). The goal for `dense` is `total_1core` <= 1 ms per light.
//!
//! The `scenes_cpu` group times the same one-core work by the CPU time of the thread that
//! runs it (`CLOCK_THREAD_CPUTIME_ID`) instead of wall time: on the shared 2-core machine
//! other processes' load stretches wall time (time slices lost to them) but not this.
//! `extract_1core` is `extract_serial`, `records_1core` is `build_records` (what the
//! renderer's CPU path builds: compact records the vertex shader expands),
//! `smoothies_1core` is `build_smoothies` (the expanded triangle list it built before, kept
//! for comparison), `total_1core` is extract + records caster by caster, as the renderer
//! does them (`speed::smoothies::CpuSmoothies::build`), `total_split_1core` the same work
//! with every caster's extraction first and then every caster's records, and
//! `penumbra_1core` is
//! penumbra-map's CPU path (`build_penumbra`: cones and sheets, Lr = the scene's light
//! radius, bases at `cone_base_depth`) and `plateaus_1core` plateaus' (`PlateauBuilder`:
//! cones and sheets in a 1024² plane texture; scenes with a planar receiver), all inside a
//! one-thread pool.
//! Before `total_split_1core`, each scene prints `total_1core`'s spread over runs timed one
//! by one (min, median, mean, p90): criterion's estimate is a mean, which a shared
//! machine's slow spells pull up.
//! `SIL_SCENES=dense,bunny` limits it to those scenes.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::{Mat4, Vec3};
use softshadow::frustum::fit_light;
use softshadow::scene::{Light, LightView, Mesh, Scene, BUILTIN_SCENES};
use softshadow::silhouette::penumbra::build_penumbra;
use softshadow::silhouette::smoothie::records::build_records;
use softshadow::silhouette::smoothie::Width;
use softshadow::silhouette::SilhouetteEdge;
use softshadow::silhouette::{
    build_smoothies, caster_adjacency, extract, extract_serial, Adjacency,
};
use softshadow::technique::penumbra_map::cone_base_depth;
use softshadow::technique::plateaus_common::{find_planar_receiver, PlaneFrame, PlateauBuilder};
use softshadow::technique::smoothies::smoothie_width;
use std::f32::consts::{PI, TAU};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

/// Mesh from a (rows + 1) x cols grid of points, wrapped in u; `wrap_v` also wraps rows.
fn grid(rows: u32, cols: u32, wrap_v: bool, f: impl Fn(f32, f32) -> Vec3) -> Mesh {
    let vrows = if wrap_v { rows } else { rows + 1 };
    let mut m = Mesh::default();
    for i in 0..vrows {
        for j in 0..cols {
            let p = f(i as f32 / rows as f32, j as f32 / cols as f32);
            m.positions.push(p);
            m.normals.push(p.normalize_or_zero());
        }
    }
    let id = |i: u32, j: u32| (i % vrows) * cols + j % cols;
    for i in 0..rows {
        for j in 0..cols {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j), id(i + 1, j + 1));
            m.indices.extend_from_slice(&[a, c, d, a, d, b]);
        }
    }
    m
}

/// UV sphere of about `2 * rings * segs` triangles (the poles are degenerate slivers,
/// which the adjacency flags and skips, as real meshes' poles often are).
fn sphere(rings: u32, segs: u32) -> Mesh {
    grid(rings, segs, false, |v, u| {
        let (th, ph) = (v * PI, u * TAU);
        Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin())
    })
}

fn torus(rings: u32, segs: u32) -> Mesh {
    grid(rings, segs, true, |v, u| {
        let (a, b) = (v * TAU, u * TAU);
        let r = 1.0 + 0.35 * a.cos();
        Vec3::new(r * b.cos(), 0.35 * a.sin(), -r * b.sin())
    })
}

fn meshes() -> Vec<(&'static str, Mesh)> {
    vec![
        ("sphere_10k", sphere(70, 72)),
        ("sphere_50k", sphere(158, 160)),
        ("torus_50k", torus(125, 200)),
    ]
}

fn bench(c: &mut Criterion) {
    let light = LightView::new(
        &Light {
            position: Vec3::new(3.0, 8.0, 2.0),
            target: Vec3::ZERO,
            fov_deg: 60.0,
            radius: 0.3,
            kind: softshadow::scene::LightKind::Spot,
        },
        0.1,
        50.0,
    );
    let model = Mat4::from_rotation_y(0.4);
    let mut g = c.benchmark_group("silhouette");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    for (name, mesh) in meshes() {
        let tris = mesh.indices.len() / 3;
        let Ok(adj) = Adjacency::build(&mesh) else {
            eprintln!("{name}: adjacency build failed");
            continue;
        };
        let sil = extract(&adj, model, light.position);
        let geo = build_smoothies(&adj, &sil, model, &light, 0.05);
        eprintln!(
            "{name}: {tris} triangles, {} edges, {} silhouette edges, {} smoothie triangles",
            adj.edges.len(),
            sil.len(),
            geo.vertices.len() / 3
        );
        g.bench_function(BenchmarkId::new("adjacency_build", name), |b| {
            b.iter(|| Adjacency::build(black_box(&mesh)))
        });
        g.bench_function(BenchmarkId::new("extract", name), |b| {
            b.iter(|| extract(black_box(&adj), model, light.position))
        });
        g.bench_function(BenchmarkId::new("extract_serial", name), |b| {
            b.iter(|| extract_serial(black_box(&adj), model, light.position))
        });
        g.bench_function(BenchmarkId::new("build_smoothies", name), |b| {
            b.iter(|| build_smoothies(black_box(&adj), black_box(&sil), model, &light, 0.05))
        });
        g.bench_function(BenchmarkId::new("extract+smoothies", name), |b| {
            b.iter(|| {
                let sil = extract(black_box(&adj), model, light.position);
                build_smoothies(&adj, &sil, model, &light, 0.05)
            })
        });
    }
    // The design's dense-1m scene: only the once-per-mesh adjacency build and one extract.
    let big = sphere(707, 708);
    eprintln!("sphere_1m: {} triangles", big.indices.len() / 3);
    g.bench_function(BenchmarkId::new("adjacency_build", "sphere_1m"), |b| {
        b.iter(|| Adjacency::build(black_box(&big)))
    });
    if let Ok(adj) = Adjacency::build(&big) {
        g.bench_function(BenchmarkId::new("extract", "sphere_1m"), |b| {
            b.iter(|| extract(black_box(&adj), model, light.position))
        });
    }
    g.finish();
}

/// One built-in scene's casters: (object to world, adjacency shared per mesh).
struct Casters {
    objects: Vec<(Mat4, Arc<Adjacency>)>,
    light: LightView,
    t: f32,
    /// The scene's light radius (penumbra-map's Lr).
    radius: f32,
    /// plateaus' plane frame (1024² texture), when the scene has a planar receiver.
    plane: Option<PlaneFrame>,
}

impl Casters {
    fn load(name: &str) -> Option<Self> {
        let scene = Scene::load(name)
            .map_err(|e| eprintln!("{name}: {e:#}"))
            .ok()?;
        let light = fit_light(&scene);
        let t = smoothie_width(None, &scene, &light, scene.light.radius);
        // As the techniques build them: one adjacency per distinct mesh, shared by the
        // objects that instance it.
        let adjacency = caster_adjacency(&scene, |_| true)
            .map_err(|e| eprintln!("{name}: {e:#}"))
            .ok()?;
        let objects = scene
            .objects
            .iter()
            .zip(adjacency)
            .filter_map(|(o, a)| a.map(|a| (o.transform, a)))
            .collect();
        let plane = find_planar_receiver(&scene)
            .ok()
            .map(|r| PlaneFrame::new(&r, scene.objects[r.object].transform, &light, 1024));
        Some(Self {
            objects,
            light,
            t,
            radius: scene.light.radius,
            plane,
        })
    }

    fn extract(&self, serial: bool) -> Vec<Vec<SilhouetteEdge>> {
        self.objects
            .iter()
            .map(|(m, adj)| {
                if serial {
                    extract_serial(adj, *m, self.light.position)
                } else {
                    extract(adj, *m, self.light.position)
                }
            })
            .collect()
    }

    /// What the renderer's CPU path builds: records for the vertex shader to expand.
    fn records(&self, sil: &[Vec<SilhouetteEdge>]) -> usize {
        self.objects
            .iter()
            .zip(sil)
            .map(|((m, adj), s)| {
                build_records(adj, s, *m, &self.light, Width::Fixed(self.t)).words()
            })
            .sum()
    }

    /// What the renderer's CPU path does per light: extract, then records, one caster after
    /// the other (`speed::smoothies::CpuSmoothies::build`), so a caster's adjacency is still
    /// in the caches when its records are built.
    fn extract_records(&self) -> usize {
        self.objects
            .iter()
            .map(|(m, adj)| {
                let sil = extract_serial(adj, *m, self.light.position);
                build_records(adj, &sil, *m, &self.light, Width::Fixed(self.t)).words()
            })
            .sum()
    }

    /// penumbra-map's CPU path: cones and sheets of every caster.
    fn penumbra(&self, sil: &[Vec<SilhouetteEdge>]) -> usize {
        let z_far = cone_base_depth(&self.light);
        self.objects
            .iter()
            .zip(sil)
            .map(|((m, adj), s)| {
                build_penumbra(adj, s, *m, &self.light, self.radius, z_far)
                    .vertices
                    .len()
            })
            .sum()
    }

    /// plateaus' CPU path: cones and sheets of every caster in the plane's texture (one
    /// mailbox stamp per caster, as the technique).
    fn plateaus(&self, sil: &[Vec<SilhouetteEdge>]) -> usize {
        let Some(plane) = &self.plane else { return 0 };
        let most = self.objects.iter().map(|(_, a)| a.positions.len()).max();
        let mut mailbox = vec![0u64; most.unwrap_or(0)];
        let mut n = 0;
        for (stamp, ((m, adj), s)) in (1..).zip(self.objects.iter().zip(sil)) {
            let mut b = PlateauBuilder::new(plane, self.radius);
            b.silhouette(adj, s, *m, &mut mailbox, stamp);
            n += b.vertices.len();
        }
        n
    }

    /// The expanded triangle list (the pre-records CPU path; the GPU path's size estimate).
    fn smoothies(&self, sil: &[Vec<SilhouetteEdge>]) -> usize {
        self.objects
            .iter()
            .zip(sil)
            .map(|((m, adj), s)| {
                build_smoothies(adj, s, *m, &self.light, self.t)
                    .vertices
                    .len()
            })
            .sum()
    }
}

fn scenes(c: &mut Criterion) {
    let one_core = rayon::ThreadPoolBuilder::new().num_threads(1).build().ok();
    let mut g = c.benchmark_group("scenes");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    for &name in BUILTIN_SCENES {
        let Some(cs) = Casters::load(name) else {
            continue;
        };
        let sil = cs.extract(false);
        let edges: usize = sil.iter().map(Vec::len).sum();
        let tris: usize = cs.objects.iter().map(|(_, a)| a.num_faces()).sum();
        eprintln!(
            "{name}: {} casters, {tris} caster triangles, {edges} silhouette edges, t = {:.4}, {} smoothie vertices",
            cs.objects.len(),
            cs.t,
            cs.smoothies(&sil)
        );
        g.bench_function(BenchmarkId::new("extract", name), |b| {
            b.iter(|| cs.extract(false))
        });
        g.bench_function(BenchmarkId::new("extract_serial", name), |b| {
            b.iter(|| cs.extract(true))
        });
        g.bench_function(BenchmarkId::new("build_smoothies", name), |b| {
            b.iter(|| cs.smoothies(black_box(&sil)))
        });
        g.bench_function(BenchmarkId::new("total", name), |b| {
            b.iter(|| cs.smoothies(&cs.extract(false)))
        });
        if let Some(pool) = &one_core {
            g.bench_function(BenchmarkId::new("total_1core", name), |b| {
                b.iter(|| pool.install(|| cs.smoothies(&cs.extract(true))))
            });
        }
    }
    g.finish();
}

/// CPU time consumed by the calling thread.
fn thread_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_THREAD_CPUTIME_ID exists on Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID)");
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

/// Prints the spread of `f`'s CPU time run by run (`total_1core`: one light's extraction and
/// records on one core), over about half a second of runs timed one by one. Criterion's
/// estimate is a mean over batches, which a shared machine's slow spells pull up (on one
/// VM, every run was up to ~1.8x slower for minutes at a time, BENCHMARKS.md);
/// the median and the minimum are what the work costs when it is not disturbed, and the
/// p90 shows how often it is.
fn per_light_summary<R>(pool: &rayon::ThreadPool, name: &str, f: impl Fn() -> R + Sync) {
    let mut ms: Vec<f64> = pool.install(|| {
        let mut ms = Vec::new();
        let start = thread_cpu_time();
        while ms.len() < 20
            || (ms.len() < 2000 && thread_cpu_time() - start < Duration::from_millis(500))
        {
            let t0 = thread_cpu_time();
            black_box(f());
            ms.push((thread_cpu_time() - t0).as_secs_f64() * 1e3);
        }
        ms
    });
    ms.sort_by(f64::total_cmp);
    let n = ms.len();
    let mean = ms.iter().sum::<f64>() / n as f64;
    eprintln!(
        "scenes_cpu/total_1core/{name}: per light, {n} runs timed one by one: min {:.3} ms, \
         median {:.3} ms, mean {mean:.3} ms, p90 {:.3} ms",
        ms[0],
        ms[n / 2],
        ms[n * 9 / 10],
    );
}

/// `iters` runs of `f` on the one thread of `pool`, timed by that thread's CPU clock.
fn cpu_iters<R>(pool: &rayon::ThreadPool, iters: u64, f: impl Fn() -> R + Sync) -> Duration {
    pool.install(|| {
        let t0 = thread_cpu_time();
        for _ in 0..iters {
            black_box(f());
        }
        thread_cpu_time() - t0
    })
}

fn scenes_cpu(c: &mut Criterion) {
    let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(1).build() else {
        eprintln!("no one-thread pool");
        return;
    };
    let mut g = c.benchmark_group("scenes_cpu");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    // SIL_SCENES=dense,bunny limits the group to those scenes (loading dense-1m takes a while).
    let only = std::env::var("SIL_SCENES").ok();
    for &name in BUILTIN_SCENES {
        if only
            .as_ref()
            .is_some_and(|o| !o.split(',').any(|s| s == name))
        {
            continue;
        }
        let Some(cs) = Casters::load(name) else {
            continue;
        };
        let sil = cs.extract(true);
        g.bench_function(BenchmarkId::new("extract_1core", name), |b| {
            b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.extract(true)))
        });
        g.bench_function(BenchmarkId::new("smoothies_1core", name), |b| {
            b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.smoothies(black_box(&sil))))
        });
        g.bench_function(BenchmarkId::new("records_1core", name), |b| {
            b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.records(black_box(&sil))))
        });
        g.bench_function(BenchmarkId::new("total_1core", name), |b| {
            b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.extract_records()))
        });
        per_light_summary(&pool, name, || cs.extract_records());
        g.bench_function(BenchmarkId::new("total_split_1core", name), |b| {
            b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.records(&cs.extract(true))))
        });
        g.bench_function(BenchmarkId::new("penumbra_1core", name), |b| {
            b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.penumbra(black_box(&sil))))
        });
        if cs.plane.is_some() {
            g.bench_function(BenchmarkId::new("plateaus_1core", name), |b| {
                b.iter_custom(|iters| cpu_iters(&pool, iters, || cs.plateaus(black_box(&sil))))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench, scenes, scenes_cpu);
criterion_main!(benches);
