//! The overwrite rule: which files a command's outputs may be written over,
//! and how they are written.
//!
//! Why: a typo (`--svg run.mcap`, `--out terrain.txt`, `record recover X.mcap
//! --out ./X.mcap`) must not cost a user the only copy of an experiment. The
//! rule, the same for every output of every command (`--svg`, `--out`,
//! `--animate`, `--record`, certificates, CSVs):
//!
//! * an output is never one of the command's own inputs, nor another output
//!   of the same run: *the same file* (device and inode after following
//!   links, or for a file still to be made its resolved directory and name),
//!   not the same spelling; refused before anything starts ([`Outputs::check`]);
//! * no file there, or an empty one: write it (nothing can be lost);
//! * a file of the output's own [`Kind`] (an SVG over an SVG): replaced only
//!   when asked to (`--force`);
//! * anything else (a recording under an SVG, a terrain, a config, a
//!   directory): never, not even with `--force`: it is not ours to replace.
//!
//! Files are written whole or not at all ([`write`]): into a temporary file
//! beside the target, synced, then renamed over it, so a crash, a full disk
//! or an error mid-way leaves the old file as it was. The one exception is a
//! launch's recording, written in place as the run goes so that a `kill -9`
//! still leaves the run on disk (see `bycoms_record`); it is checked by the
//! same rule before the launch starts.

use std::fs::{File, Permissions};
use std::io::{Read, Write};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

use super::kind::{Kind, HEAD};

/// Why an output may not be written where it was asked to go.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output is one of the command's inputs.
    #[error("{flag} {}: that is the input {}; refusing to overwrite an input", path.display(), input.display())]
    IsInput {
        /// The flag that named the output.
        flag: String,
        /// The output.
        path: PathBuf,
        /// The input it is (as the user spelled it).
        input: PathBuf,
    },
    /// Two outputs of one run are the same file.
    #[error("{flag} {} and {other} {} are the same file; give each output its own", path.display(), other_path.display())]
    SameOutput {
        /// The flag of the later output.
        flag: String,
        /// Its path.
        path: PathBuf,
        /// The flag of the earlier output.
        other: String,
        /// Its path.
        other_path: PathBuf,
    },
    /// A file of the output's own kind, without `--force`.
    #[error("{} is already {}; give --force to replace it", path.display(), kind.name())]
    Exists {
        /// The file.
        path: PathBuf,
        /// Its kind (the output's).
        kind: Kind,
    },
    /// A file of another kind (or a directory): never replaced.
    #[error("{} exists and is {found}, not {}; refusing to overwrite it (even with --force)", path.display(), kind.name())]
    OtherKind {
        /// The file.
        path: PathBuf,
        /// The output's kind.
        kind: Kind,
        /// What is there, in words.
        found: String,
    },
    /// The file could not be inspected.
    #[error("cannot inspect {}", path.display())]
    Inspect {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// Writing the file failed (the old one, if any, is untouched).
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
}

/// The error a command ends with: a broken rule is a usage error (exit 2,
/// nothing was written), a failed inspection or write an error (exit 1).
pub fn usage_unless_io(error: OutputError) -> anyhow::Error {
    match error {
        OutputError::Inspect { .. } | OutputError::Write { .. } => error.into(),
        rule => crate::exit::usage(rule),
    }
}

/// [`usage_unless_io`], with a failed write said as "cannot write `what` to
/// PATH: cause" ("the snapshot", "the picture").
pub fn writing(what: &str) -> impl Fn(OutputError) -> anyhow::Error + '_ {
    move |error| match error {
        OutputError::Write { path, source } => {
            anyhow::Error::new(source).context(format!("cannot write {what} to {}", path.display()))
        }
        other => usage_unless_io(other),
    }
}

/// Checks that a file of `kind` may be written to `path` (see the module
/// documentation); `force` allows replacing a file of the same kind.
pub fn check_target(path: &Path, kind: Kind, force: bool) -> Result<(), OutputError> {
    let inspect = |source| OutputError::Inspect { path: path.to_path_buf(), source };
    let meta = match std::fs::metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(inspect(e)),
    };
    if !meta.is_file() {
        let found = if meta.is_dir() { "a directory" } else { "not a regular file" };
        return Err(OutputError::OtherKind { path: path.to_path_buf(), kind, found: found.into() });
    }
    if meta.len() == 0 {
        return Ok(());
    }
    let mut head = Vec::with_capacity(HEAD);
    File::open(path).and_then(|f| f.take(HEAD as u64).read_to_end(&mut head)).map_err(inspect)?;
    match (kind.matches(&head), force) {
        (true, true) => Ok(()),
        (true, false) => Err(OutputError::Exists { path: path.to_path_buf(), kind }),
        (false, _) => {
            let found = Kind::of(&head).map_or("something else", Kind::name);
            Err(OutputError::OtherKind { path: path.to_path_buf(), kind, found: found.into() })
        }
    }
}

/// Whether an output at `path` may replace a file of its own kind: with
/// `--force`, or when `path` is the command's own default name for it
/// (`default`, e.g. `simulate.svg`). Why: running the README's first
/// command twice in one folder must work; what a command wrote at its own
/// default name is its own to replace, and only with its own kind (an SVG
/// over an SVG: a recording or a terrain there is still never touched).
pub fn replaces(force: bool, path: &Path, default: &str) -> bool {
    fn plain(p: &Path) -> Vec<std::path::Component<'_>> {
        p.components().filter(|c| *c != std::path::Component::CurDir).collect()
    }
    force || plain(path) == plain(Path::new(default))
}

/// The place of an output must take a new file: its directory (or, when
/// the command makes the missing folders, `making_folders`, the nearest
/// existing one) is probed with a temporary file, gone at once. Why: a
/// picture to a missing or read-only folder was found unwritable only
/// after the run it pictures.
fn check_place(path: &Path, making_folders: bool) -> Result<(), OutputError> {
    let failed = |source| OutputError::Write { path: path.to_path_buf(), source };
    let mut dir = parent(path);
    loop {
        match std::fs::metadata(dir) {
            Ok(meta) if meta.is_dir() => break,
            Ok(_) => {
                let what = format!("{} is not a directory", dir.display());
                return Err(failed(std::io::Error::new(std::io::ErrorKind::NotADirectory, what)));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && making_folders && parent(dir) != dir => {
                dir = parent(dir);
            }
            Err(e) => return Err(failed(e)),
        }
    }
    tempfile::tempfile_in(dir).map(drop).map_err(failed)
}

/// What a path names, for telling whether two paths are the same file.
#[derive(Debug, PartialEq, Eq, Hash)]
enum Identity {
    /// An existing file: device and inode (links followed).
    File(u64, u64),
    /// A file still to be made: its resolved directory and its name.
    Path(PathBuf),
}

fn identity(path: &Path) -> Result<Identity, OutputError> {
    match std::fs::metadata(path) {
        Ok(meta) => Ok(Identity::File(meta.dev(), meta.ino())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let dir = parent(path);
            let dir = dir.canonicalize().unwrap_or_else(|_| std::path::absolute(dir).unwrap_or(dir.into()));
            Ok(Identity::Path(dir.join(path.file_name().unwrap_or_default())))
        }
        Err(source) => Err(OutputError::Inspect { path: path.to_path_buf(), source }),
    }
}

/// The directory `path` is in (`.` for a bare file name).
fn parent(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// A command's inputs and outputs, checked together before it starts.
#[derive(Debug, Default)]
pub struct Outputs {
    inputs: Vec<PathBuf>,
    outputs: Vec<(String, PathBuf, Kind, bool)>,
    force: bool,
    making_folders: bool,
}

impl Outputs {
    /// No inputs or outputs yet; `force` is the command's `--force`.
    pub fn new(force: bool) -> Outputs {
        Outputs { force, ..Outputs::default() }
    }

    /// The command makes the folders its outputs go in (`terrain --out
    /// DIR`, `certs --out DIR`): a missing one is fine if the nearest
    /// existing folder takes files.
    pub fn making_folders(mut self) -> Outputs {
        self.making_folders = true;
        self
    }

    /// A file the command reads.
    pub fn input(mut self, path: impl AsRef<Path>) -> Outputs {
        self.inputs.push(path.as_ref().to_path_buf());
        self
    }

    /// A file of `kind` the command writes, named by `flag` (for messages).
    pub fn output(mut self, flag: &str, path: impl AsRef<Path>, kind: Kind) -> Outputs {
        self.outputs.push((flag.to_string(), path.as_ref().to_path_buf(), kind, self.force));
        self
    }

    /// An output whose command has a default name for it (`simulate.svg`):
    /// at that name a file of its own kind is replaced without `--force`
    /// ([`replaces`]).
    pub fn default_output(
        mut self,
        flag: &str,
        path: impl AsRef<Path>,
        kind: Kind,
        default: &str,
    ) -> Outputs {
        let force = replaces(self.force, path.as_ref(), default);
        self.outputs.push((flag.to_string(), path.as_ref().to_path_buf(), kind, force));
        self
    }

    /// Applies the rule to every output: not an input, not another output,
    /// and [`check_target`]. Call it before anything starts.
    pub fn check(&self) -> Result<(), OutputError> {
        use std::collections::{HashMap, HashSet};
        let mut inputs = HashMap::new();
        for input in &self.inputs {
            // An input that does not exist is the command's own error to report.
            if let Ok(id @ Identity::File(..)) = identity(input) {
                inputs.entry(id).or_insert(input);
            }
        }
        // By identity and by folder probed: a command with thousands of
        // outputs (`certs --robots 1000`) checks each once, not each against all.
        let mut seen: HashMap<Identity, (&str, &Path)> = HashMap::new();
        let mut probed = HashSet::new();
        for (flag, path, kind, force) in &self.outputs {
            if probed.insert(parent(path).to_path_buf()) {
                check_place(path, self.making_folders)?;
            }
            let id = identity(path)?;
            if let Some(input) = inputs.get(&id) {
                return Err(OutputError::IsInput {
                    flag: flag.clone(),
                    path: path.clone(),
                    input: input.to_path_buf(),
                });
            }
            if let Some((other, other_path)) = seen.get(&id) {
                return Err(OutputError::SameOutput {
                    flag: flag.clone(),
                    path: path.clone(),
                    other: other.to_string(),
                    other_path: other_path.to_path_buf(),
                });
            }
            check_target(path, *kind, *force)?;
            seen.insert(id, (flag, path));
        }
        Ok(())
    }
}

/// Writes `bytes` as a file of `kind` at `path` under the rule
/// ([`check_target`] again, in case something appeared since the command's
/// [`Outputs::check`]), atomically: a temporary file beside `path`, synced,
/// renamed over it. Mode 0666 less the umask, as `File::create` would.
pub fn write(path: &Path, kind: Kind, force: bool, bytes: &[u8]) -> Result<(), OutputError> {
    check_target(path, kind, force)?;
    write_atomic(path, bytes, 0o666)
}

/// [`write`] for a private key: mode 0600.
pub fn write_private(path: &Path, kind: Kind, force: bool, bytes: &[u8]) -> Result<(), OutputError> {
    check_target(path, kind, force)?;
    write_atomic(path, bytes, 0o600)
}

/// The temporary-file-and-rename half of [`write`], for callers that write
/// into a directory they own (a sweep's output directory).
pub fn write_atomic(path: &Path, bytes: &[u8], mode: u32) -> Result<(), OutputError> {
    let failed = |e| OutputError::Write { path: path.to_path_buf(), source: without_temp_path(e) };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .permissions(Permissions::from_mode(mode))
        .tempfile_in(parent(path))
        .map_err(failed)?;
    tmp.write_all(bytes).and_then(|()| tmp.as_file().sync_all()).map_err(failed)?;
    tmp.persist(path).map_err(|e| failed(e.error))?;
    Ok(())
}

/// Writes a file through `fill` into a temporary file beside `path`, and
/// renames it over `path` only when `fill` succeeded (else the temporary
/// file is removed and `path` is untouched). For large outputs written as a
/// stream (`record recover`); the caller has checked the target.
pub fn write_with<T, E>(
    path: &Path,
    fill: impl FnOnce(File) -> Result<(T, File), E>,
) -> Result<Result<T, E>, OutputError> {
    let failed = |e| OutputError::Write { path: path.to_path_buf(), source: without_temp_path(e) };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .permissions(Permissions::from_mode(0o666))
        .tempfile_in(parent(path))
        .map_err(failed)?;
    let (file, tmp_path) = tmp.into_parts();
    match fill(file) {
        Ok((value, file)) => {
            file.sync_all().map_err(failed)?;
            tmp_path.persist(path).map_err(|e| failed(e.error))?;
            Ok(Ok(value))
        }
        Err(e) => Ok(Err(e)),
    }
}

/// The operating system's error without the temporary file's name that
/// `tempfile` adds ("… at path /dir/.x.svg.tmp"): the user named the target.
fn without_temp_path(e: std::io::Error) -> std::io::Error {
    let text = e.to_string();
    match (e.get_ref().is_some(), text.split_once(" at path \"")) {
        (true, Some((what, _))) => std::io::Error::new(e.kind(), what.to_string()),
        _ => e,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recording(path: &Path) {
        let mut bytes = crate::out::kind::MCAP_MAGIC.to_vec();
        bytes.extend_from_slice(b"rest of a recording");
        std::fs::write(path, bytes).expect("recording");
    }

    #[test]
    fn new_and_empty_files_are_fine_own_kind_needs_force_and_others_are_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let new = dir.path().join("new.mcap");
        assert!(check_target(&new, Kind::Recording, false).is_ok());
        std::fs::write(&new, b"").expect("empty");
        assert!(check_target(&new, Kind::Svg, false).is_ok(), "an empty file holds nothing");

        let rec = dir.path().join("old.mcap");
        recording(&rec);
        let refused = check_target(&rec, Kind::Recording, false).expect_err("a recording without --force");
        assert!(matches!(refused, OutputError::Exists { .. }) && refused.to_string().contains("--force"));
        assert!(check_target(&rec, Kind::Recording, true).is_ok());
        for force in [false, true] {
            let refused = check_target(&rec, Kind::Svg, force).expect_err("an SVG over a recording");
            assert!(refused.to_string().contains("is an MCAP recording, not an SVG picture"), "{refused}");
        }

        let terrain = dir.path().join("terrain.txt");
        std::fs::write(&terrain, b"....#...\n").expect("terrain");
        for (kind, force) in [(Kind::Recording, true), (Kind::Svg, true), (Kind::Csv, false)] {
            let refused = check_target(&terrain, kind, force).expect_err("not ours");
            assert!(matches!(refused, OutputError::OtherKind { .. }), "{refused}");
        }
        assert!(matches!(check_target(dir.path(), Kind::Svg, true), Err(OutputError::OtherKind { .. })));
    }

    #[test]
    fn an_output_that_is_an_input_or_another_output_is_refused_however_it_is_spelled() {
        let dir = tempfile::tempdir().expect("temp dir");
        let rec = dir.path().join("x.mcap");
        recording(&rec);
        let link = dir.path().join("link.mcap");
        std::os::unix::fs::symlink(&rec, &link).expect("symlink");
        let hard = dir.path().join("hard.mcap");
        std::fs::hard_link(&rec, &hard).expect("hard link");
        let dotted = dir.path().join(".").join("x.mcap");
        for out in [&rec, &link, &hard, &dotted] {
            let refused = Outputs::new(true).input(&rec).output("--out", out, Kind::Recording).check();
            assert!(matches!(refused, Err(OutputError::IsInput { .. })), "{out:?}: {refused:?}");
        }
        let svg = dir.path().join("new.svg");
        let same = dir.path().join("sub/../new.svg");
        std::fs::create_dir(dir.path().join("sub")).expect("sub");
        let refused = Outputs::new(true)
            .input(&rec)
            .output("--svg", &svg, Kind::Svg)
            .output("--animate", &same, Kind::Svg)
            .check()
            .expect_err("two outputs, one file");
        assert!(
            refused.to_string().contains("--animate") && refused.to_string().contains("--svg"),
            "{refused}"
        );
        let other = dir.path().join("other.svg");
        assert!(Outputs::new(false)
            .input(&rec)
            .output("--svg", &svg, Kind::Svg)
            .output("--animate", &other, Kind::Svg)
            .check()
            .is_ok());
    }

    #[test]
    fn an_output_whose_place_takes_no_file_is_refused_before_the_work() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("plain.txt");
        std::fs::write(&file, b"x").expect("file");
        for out in [file.join("run.svg"), file.join("deeper/run.svg")] {
            for rule in [Outputs::new(true), Outputs::new(true).making_folders()] {
                let refused = rule.output("--svg", &out, Kind::Svg).check().expect_err("no place");
                assert!(matches!(refused, OutputError::Write { .. }), "{refused:?}");
                assert!(refused.to_string().contains("cannot write"), "{refused}");
            }
        }
        // Missing folders are refused, unless the command makes them.
        let deep = dir.path().join("a/b/run.svg");
        let refused = Outputs::new(false).output("--svg", &deep, Kind::Svg).check().expect_err("no folder");
        assert!(refused.to_string().contains("cannot write"), "{refused}");
        assert!(Outputs::new(false).making_folders().output("--svg", &deep, Kind::Svg).check().is_ok());
        assert!(!dir.path().join("a").exists(), "the probe leaves nothing behind");
        let names: Vec<_> = std::fs::read_dir(dir.path()).expect("list").collect();
        assert_eq!(names.len(), 1, "only plain.txt: {names:?}");
    }

    #[test]
    fn a_command_replaces_its_own_kind_at_its_default_name_without_force() {
        assert!(replaces(false, Path::new("simulate.svg"), "simulate.svg"));
        assert!(replaces(false, Path::new("./simulate.svg"), "simulate.svg"));
        assert!(!replaces(false, Path::new("other.svg"), "simulate.svg"));
        assert!(!replaces(false, Path::new("sub/simulate.svg"), "simulate.svg"));
        assert!(replaces(true, Path::new("other.svg"), "simulate.svg"));
        let dir = tempfile::tempdir().expect("temp dir");
        let svg = dir.path().join("simulate.svg");
        std::fs::write(&svg, b"<svg></svg>").expect("svg");
        let own = Outputs::new(false).default_output("--svg", &svg, Kind::Svg, svg.to_str().expect("utf-8"));
        assert!(own.check().is_ok(), "its own default picture");
        std::fs::write(&svg, b"S..\n..G\n").expect("terrain");
        let other =
            Outputs::new(false).default_output("--svg", &svg, Kind::Svg, svg.to_str().expect("utf-8"));
        assert!(matches!(other.check(), Err(OutputError::OtherKind { .. })), "never another kind");
    }

    #[test]
    fn writes_replace_whole_files_and_leave_no_temporary_behind() {
        let dir = tempfile::tempdir().expect("temp dir");
        let svg = dir.path().join("a.svg");
        write(&svg, Kind::Svg, false, b"<svg>one</svg>").expect("new file");
        assert!(write(&svg, Kind::Svg, false, b"<svg>two</svg>").is_err(), "an SVG needs --force");
        write(&svg, Kind::Svg, true, b"<svg>two</svg>").expect("forced");
        assert_eq!(std::fs::read(&svg).expect("read"), b"<svg>two</svg>");
        let key = dir.path().join("k.pem");
        write_private(&key, Kind::Pem, false, b"-----BEGIN PRIVATE KEY-----\n").expect("key");
        assert_eq!(std::fs::metadata(&key).expect("meta").permissions().mode() & 0o777, 0o600);
        let kept: Result<Result<(), &str>, _> = write_with(&dir.path().join("b.mcap"), |_| Err("failed"));
        assert_eq!(kept.expect("no I/O error"), Err("failed"));
        let names: Vec<_> =
            std::fs::read_dir(dir.path()).expect("list").map(|e| e.expect("entry").file_name()).collect();
        assert_eq!(names.len(), 2, "only a.svg and k.pem: {names:?}");
    }
}
