//! Writing results: the PNG and the `--aov` EXRs of docs/DESIGN.md, and the checks and staging that
//! keep every command's outputs all-or-nothing.
//!
//! A command checks each output path before any work ([`check_file`], [`check_dir`]): a path
//! that exists as something other than a regular file (a folder, a device node, a FIFO) is
//! refused, as is a missing or read-only parent folder. Its files are then written to hidden
//! temporary names beside their final ones ([`Publish::stage`]) and renamed into place
//! together by [`Publish::commit`]; a failure while staging removes every temporary file and
//! every folder the command created, and a failure while renaming puts back what was there.
//!
//! Staged files and folders (`Publish`'s and `bench`'s) are also listed for an interrupt:
//! the binary installs [`remove_pending_on_interrupt`], so Ctrl-C (SIGINT), SIGTERM or
//! SIGHUP removes them before the process exits with status 130. A process killed outright
//! (SIGKILL) cannot clean up: its leftovers carry its process id, and the next command that
//! stages beside them removes those of dead processes ([`remove_stale`]).

use anyhow::{anyhow, bail, Context as _, Result};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, WritableImage,
};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Staged paths an interrupt removes, with a registration number each.
static PENDING: Mutex<Vec<(u64, PathBuf)>> = Mutex::new(Vec::new());
static NEXT_PENDING: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// A staged file or folder listed for removal on an interrupt; dropping it takes it off the
/// list (the owner publishes or removes it itself).
pub struct Pending(u64);

impl Pending {
    pub fn new(path: &Path) -> Self {
        let id = NEXT_PENDING.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if let Ok(mut list) = PENDING.lock() {
            list.push((id, path.to_path_buf()));
        }
        Self(id)
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Ok(mut list) = PENDING.lock() {
            list.retain(|(id, _)| *id != self.0);
        }
    }
}

/// Removes every pending staged path; what is removed is our own temporary output only.
/// For the binary's exits that skip unwinding (a panic) as well as for an interrupt.
pub fn remove_pending_outputs() {
    let list = match PENDING.lock() {
        Ok(list) => list.clone(),
        Err(poisoned) => poisoned.into_inner().clone(),
    };
    for (_, path) in list {
        match std::fs::symlink_metadata(&path) {
            Ok(md) if md.is_dir() => {
                let _ = std::fs::remove_dir_all(&path);
            }
            Ok(_) => {
                let _ = std::fs::remove_file(&path);
            }
            Err(_) => {}
        }
    }
}

/// Installs the handler of SIGINT, SIGTERM and SIGHUP: it removes every pending staged path
/// and exits with status 130 after one `error:` line. The handler runs on a thread of its
/// own (the `ctrlc` crate), not in signal context, so it may take locks and touch files.
pub fn remove_pending_on_interrupt() -> Result<()> {
    ctrlc::set_handler(|| {
        remove_pending_outputs();
        eprintln!("error: interrupted; partial output removed");
        std::process::exit(130);
    })
    .map_err(|e| anyhow!("cannot install the interrupt handler: {e}"))
}

/// Whether the process `pid` is gone (None: cannot tell, without /proc).
fn process_gone(pid: u32) -> Option<bool> {
    if !Path::new("/proc/self").exists() {
        return None;
    }
    Some(pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists())
}

/// Removes the entries of `dir` named `{prefix}{pid}` (files or folders) whose process is
/// gone: what a killed command left. A live process's entries, ours included, and anything
/// else are left alone; without /proc nothing is removed.
pub fn remove_stale(dir: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name.strip_prefix(prefix) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if process_gone(pid) == Some(true) {
            let path = e.path();
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                let _ = std::fs::remove_dir_all(path);
            } else {
                let _ = std::fs::remove_file(path);
            }
        }
    }
}

/// The folder a file path lands in (`.` for a bare name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Whether files can be created in `dir`: creates and removes a probe file, which answers for
/// permissions, read-only mounts and ACLs alike.
fn probe_writable(dir: &Path) -> std::io::Result<()> {
    let probe = dir.join(format!(".softshadow-probe-{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)?;
    std::fs::remove_file(&probe)
}

/// Refuses `path` unless it is absent or a regular file (following symlinks): renaming over a
/// device node or a FIFO would replace it.
fn check_not_special(path: &Path, flag: &str) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(md) if md.is_dir() => bail!("{flag} {}: it is a folder, not a file", path.display()),
        Ok(md) if !md.is_file() => bail!(
            "{flag} {}: it exists and is not a regular file (a device, FIFO or socket); refusing to replace it",
            path.display()
        ),
        _ => Ok(()),
    }
}

/// Whether two existing paths name one file: the same device and inode (a symlink, a hard
/// link, `./a.png` and `a.png`), else the same canonical path.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}

/// Refuses, before any work, an output `path` that is one of the command's `inputs`
/// ((option, path) pairs), however either is spelt: writing it would replace what the
/// command reads. An output that does not exist yet is no input.
pub fn check_not_input(path: &Path, flag: &str, inputs: &[(&str, PathBuf)]) -> Result<()> {
    if std::fs::metadata(path).is_err() {
        return Ok(());
    }
    for (what, input) in inputs {
        if same_file(path, input) {
            bail!(
                "{flag} {}: it is the same file as {what} {}; refusing to overwrite an input",
                path.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Checks, before any work, that `path` can be written as a file: it is absent or a regular
/// file, its folder exists and is writable. `flag` names the option in the error.
pub fn check_file(path: &Path, flag: &str) -> Result<()> {
    check_not_special(path, flag)?;
    let dir = parent_of(path);
    if !dir.is_dir() {
        bail!(
            "{flag} {}: folder {} does not exist",
            path.display(),
            dir.display()
        );
    }
    probe_writable(dir).map_err(|e| {
        anyhow!(
            "{flag} {}: cannot write into folder {}: {e}",
            path.display(),
            dir.display()
        )
    })
}

/// Checks, before any work, that `dir` can hold output files: it is a folder, or it does not
/// exist and its nearest existing ancestor is a writable folder (it is created on commit).
pub fn check_dir(dir: &Path, flag: &str) -> Result<()> {
    let mut at = dir.to_path_buf();
    loop {
        match std::fs::metadata(&at) {
            Ok(md) if md.is_dir() => break,
            Ok(_) if at == dir => bail!("{flag} {}: it exists and is not a folder", dir.display()),
            Ok(_) => bail!(
                "{flag} {}: cannot create output folder: {} is not a folder",
                dir.display(),
                at.display()
            ),
            Err(_) => {
                at = match at.parent() {
                    Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                    _ => PathBuf::from("."),
                };
            }
        }
    }
    probe_writable(&at).map_err(|e| {
        anyhow!(
            "{flag} {}: cannot write into folder {}: {e}",
            dir.display(),
            at.display()
        )
    })
}

/// A hidden sibling of `path` with `tag` and the process id, in the same folder so that a
/// rename into place is atomic.
fn sibling(path: &Path, tag: &str) -> PathBuf {
    path.with_file_name(format!(
        "{}{}",
        sibling_prefix(path, tag),
        std::process::id()
    ))
}

/// `.{file name}.{tag}-`, the name of `sibling` without its process id.
fn sibling_prefix(path: &Path, tag: &str) -> String {
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    format!(".{file}.{tag}-")
}

/// The files of one command, staged under temporary names and published together (see the
/// module docs). Dropped without [`Publish::commit`], it removes what it staged and the
/// folders it created.
#[derive(Default)]
pub struct Publish {
    /// (temporary, final) pairs in staging order.
    staged: Vec<(PathBuf, PathBuf)>,
    /// The temporary files, listed for removal on an interrupt.
    pending: Vec<Pending>,
    /// Folders this command created, outermost first.
    created: Vec<PathBuf>,
}

impl Publish {
    pub fn new() -> Self {
        Self::default()
    }

    /// Creates `dir` (and missing ancestors), remembering what it created so a failure can
    /// remove it again.
    pub fn create_dir(&mut self, dir: &Path) -> Result<()> {
        let mut missing = Vec::new();
        let mut at = dir.to_path_buf();
        while !at.as_os_str().is_empty() && std::fs::symlink_metadata(&at).is_err() {
            missing.push(at.clone());
            at = at.parent().map(Path::to_path_buf).unwrap_or_default();
        }
        for d in missing.into_iter().rev() {
            std::fs::create_dir(&d)
                .with_context(|| format!("cannot create folder {}", d.display()))?;
            self.created.push(d);
        }
        if !dir.is_dir() {
            bail!("{}: it exists and is not a folder", dir.display());
        }
        Ok(())
    }

    /// Writes `path`'s content through `write` into a temporary file beside it.
    pub fn stage(&mut self, path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
        check_not_special(path, "output")?;
        remove_stale(parent_of(path), &sibling_prefix(path, "partial"));
        let tmp = sibling(path, "partial");
        // Registered first so that a failing write's leftovers are removed too.
        self.staged.push((tmp.clone(), path.to_path_buf()));
        self.pending.push(Pending::new(&tmp));
        write(&tmp).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Renames every staged file into place; on a failure, puts back every file it replaced.
    pub fn commit(mut self) -> Result<()> {
        let staged = std::mem::take(&mut self.staged);
        // Refused before anything moves: something may have appeared since the first check.
        for (_, to) in &staged {
            check_not_special(to, "output")?;
        }
        // (final, its backup if one existed) for every file renamed so far.
        let mut done: Vec<(PathBuf, Option<PathBuf>)> = Vec::new();
        let mut pending = staged.iter();
        let result = (|| -> Result<()> {
            for (tmp, to) in pending.by_ref() {
                let backup = if to.exists() {
                    let b = sibling(to, "previous");
                    std::fs::rename(to, &b)
                        .with_context(|| format!("cannot replace {}", to.display()))?;
                    Some(b)
                } else {
                    None
                };
                let moved = std::fs::rename(tmp, to);
                done.push((to.clone(), backup));
                moved.with_context(|| format!("cannot write {}", to.display()))?;
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                for (_, backup) in done {
                    if let Some(b) = backup {
                        let _ = std::fs::remove_file(b);
                    }
                }
                self.created.clear();
                Ok(())
            }
            Err(e) => {
                for (to, backup) in done.into_iter().rev() {
                    match backup {
                        Some(b) => {
                            let _ = std::fs::rename(b, &to);
                        }
                        None => {
                            let _ = std::fs::remove_file(&to);
                        }
                    }
                }
                // What was not renamed is removed by drop.
                self.staged = staged;
                Err(e)
            }
        }
    }
}

impl Drop for Publish {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
        }
        for d in self.created.iter().rev() {
            // Only succeeds when empty: never removes anything but our own folder.
            let _ = std::fs::remove_dir(d);
        }
    }
}

/// Writes one file through a temporary name renamed into place.
fn write_one(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let mut p = Publish::new();
    p.stage(path, write)?;
    p.commit()
}

/// Which image format a file name asks for: only `.png` is written.
pub fn check_png_name(path: &Path, flag: &str) -> Result<()> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") => Ok(()),
        Some(e) => bail!(
            "{flag} {}: .{e} is not supported, only PNG is written (name the file .png)",
            path.display()
        ),
        None => bail!(
            "{flag} {}: no extension, only PNG is written (name the file .png)",
            path.display()
        ),
    }
}

/// The image and AOVs of a frame, read back to the host, row 0 at the top (what
/// `render::Renderer::read_back` returns and the writers below write).
pub struct FrameImages {
    pub width: u32,
    pub height: u32,
    pub color: Vec<[u8; 4]>,
    pub visibility: Vec<f32>,
    pub position: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 3]>,
    /// The spot factor the final pass shaded each pixel with, in [0, 1]: 0 outside the
    /// light's cone (where no light falls) and on the background.
    pub spot: Vec<f32>,
}

/// The image crate wraps I/O errors and returns the same error as its source, so `{:#}`
/// would print the cause twice; unwrapped here.
pub fn image_error(e: image::ImageError) -> anyhow::Error {
    match e {
        image::ImageError::IoError(io) => io.into(),
        other => anyhow!("{other}"),
    }
}

/// Encodes the shaded image as an 8-bit RGBA PNG into `path` (no staging).
pub fn encode_png(path: &Path, frame: &FrameImages) -> Result<()> {
    let bytes: Vec<u8> = frame.color.iter().flatten().copied().collect();
    let img = image::RgbaImage::from_raw(frame.width, frame.height, bytes)
        .context("image size does not match its pixels")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(image_error)
}

/// The shaded image as an 8-bit RGBA PNG, through a temporary file.
pub fn write_png(path: &Path, frame: &FrameImages) -> Result<()> {
    write_one(path, |tmp| encode_png(tmp, frame))
}

/// Encodes an EXR of 32-bit float channels named `names`, `channels[c][pixel]` into `path`
/// (no staging).
pub fn encode_exr(
    path: &Path,
    width: u32,
    height: u32,
    names: &[&str],
    channels: Vec<Vec<f32>>,
) -> Result<()> {
    let list: Vec<AnyChannel<FlatSamples>> = names
        .iter()
        .zip(channels)
        .map(|(n, data)| AnyChannel::new(*n, FlatSamples::F32(data)))
        .collect();
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list.into()),
    );
    let image = Image::from_layer(layer);
    image.write().to_file(path).map_err(|e| match e {
        exr::error::Error::Io(io) => anyhow::Error::from(io),
        other => anyhow!("{other}"),
    })
}

/// An EXR of 32-bit float channels, through a temporary file.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    names: &[&str],
    channels: Vec<Vec<f32>>,
) -> Result<()> {
    write_one(path, |tmp| encode_exr(tmp, width, height, names, channels))
}

/// Stages `DIR/visibility.exr` (one channel `Y`), `DIR/position.exr` (RGBA) and
/// `DIR/normal.exr` (RGB the normal, A the spot factor) into `publish`.
pub fn stage_aovs(publish: &mut Publish, dir: &Path, frame: &FrameImages) -> Result<()> {
    publish.create_dir(dir)?;
    let (w, h) = (frame.width, frame.height);
    publish.stage(&dir.join("visibility.exr"), |t| {
        encode_exr(t, w, h, &["Y"], vec![frame.visibility.clone()])
    })?;
    let pos: Vec<Vec<f32>> = (0..4)
        .map(|c| frame.position.iter().map(|p| p[c]).collect())
        .collect();
    publish.stage(&dir.join("position.exr"), |t| {
        encode_exr(t, w, h, &["R", "G", "B", "A"], pos)
    })?;
    let mut nrm: Vec<Vec<f32>> = (0..3)
        .map(|c| frame.normal.iter().map(|p| p[c]).collect())
        .collect();
    nrm.push(frame.spot.clone());
    publish.stage(&dir.join("normal.exr"), |t| {
        encode_exr(t, w, h, &["R", "G", "B", "A"], nrm)
    })
}

/// `DIR/visibility.exr`, `DIR/position.exr` and `DIR/normal.exr`, published together.
pub fn write_aovs(dir: &Path, frame: &FrameImages) -> Result<()> {
    let mut p = Publish::new();
    stage_aovs(&mut p, dir, frame)?;
    p.commit()
}
