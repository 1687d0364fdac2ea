//! The imported structures of this process, read and reduced once per distinct input.
//!
//! A sweep or an optimisation builds its scenario at every evaluation, but the design
//! variables (mechanisms, generators, loads) never change the structure: the files, their
//! damping and the Craig–Bampton settings. Reading, checking and reducing the bundled
//! frame is most of a linearised evaluation's cost, so both are kept:
//!
//! - [`load`]: the [`ImportedStructure`] of a [`StructureSource`]: files keyed by every
//!   file's path and contents and the damping input (an edited file is read again), parts
//!   given in memory by their identity (the cache holds them) and the damping input;
//! - [`reduce`]: its Craig–Bampton reduction, keyed by the same and the number of modes
//!   and the interface DOFs.
//!
//! Each distinct key is computed once, also when parallel sweep points ask for it at the
//! same time (the others wait for the first), by the same deterministic functions as
//! without the cache, so every result is bit-identical to a fresh computation. Results
//! are handed out as clones (the callers own their structure); errors are kept too (the
//! same files fail the same way). At most [`CAPACITY`] entries of each kind are kept, the
//! oldest dropped first.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use diagnostic::Diagnostics;
use fem_structure::{
    DampingInput, ImportedStructure, MatrixFiles, Reduced, StructureParts, craig_bampton,
};

use crate::scenario::hybrid::StructureSource;

/// Most entries kept in each cache.
pub const CAPACITY: usize = 8;

/// What identifies an imported structure's input: each file's path and contents, the
/// damping ratios (as bits).
#[derive(Clone, Debug, PartialEq, Eq)]
struct FilesKey {
    files: Vec<(PathBuf, Vec<u8>)>,
    ratios: Option<[(usize, u64); 2]>,
}

impl FilesKey {
    /// `None` when a file cannot be read (the uncached path then reports it).
    fn of(f: &MatrixFiles) -> Option<FilesKey> {
        let mut paths = vec![&f.mass, &f.stiffness, &f.nodes, &f.dofs];
        let ratios = match &f.damping {
            DampingInput::None => None,
            DampingInput::Matrix(p) => {
                paths.push(p);
                None
            }
            DampingInput::Ratios(r) => Some(r.map(|(m, z)| (m, z.to_bits()))),
        };
        let files = paths
            .into_iter()
            .map(|p| Some((p.clone(), std::fs::read(p).ok()?)))
            .collect::<Option<Vec<_>>>()?;
        Some(FilesKey { files, ratios })
    }
}

/// The damping ratios of a damping input, as bits (`None` for none or a matrix).
fn ratio_bits(d: &DampingInput) -> Option<[(usize, u64); 2]> {
    match d {
        DampingInput::Ratios(r) => Some(r.map(|(m, z)| (m, z.to_bits()))),
        _ => None,
    }
}

/// What identifies a structure's input: its files ([`FilesKey`]), or its parts given in
/// memory — the same parts (held here, so never freed while the key lives) — and their
/// damping input.
#[derive(Clone, Debug)]
enum SourceKey {
    Files(FilesKey),
    Given(Arc<StructureParts>, bool, Option<[(usize, u64); 2]>),
}

impl PartialEq for SourceKey {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (SourceKey::Files(a), SourceKey::Files(b)) => a == b,
            (SourceKey::Given(p, m, r), SourceKey::Given(q, n, s)) => {
                Arc::ptr_eq(p, q) && m == n && r == s
            }
            _ => false,
        }
    }
}

impl SourceKey {
    /// `None` when a file cannot be read (the uncached path then reports it).
    fn of(source: &StructureSource) -> Option<SourceKey> {
        match source {
            StructureSource::Files(f) => FilesKey::of(f).map(SourceKey::Files),
            StructureSource::Given { parts, damping } => Some(SourceKey::Given(
                Arc::clone(parts),
                matches!(damping, DampingInput::Matrix(_)),
                ratio_bits(damping),
            )),
        }
    }
}

/// The structure of `source`, computed.
fn from_source(source: &StructureSource) -> Result<ImportedStructure, Diagnostics> {
    match source {
        StructureSource::Files(f) => ImportedStructure::from_files(f),
        StructureSource::Given { parts, damping } => parts.model(damping),
    }
}

/// One computed value and how many times it was computed (at most once).
struct Slot<V> {
    value: OnceLock<V>,
    computed: AtomicUsize,
}

/// A small keyed store of values computed once.
struct Cache<K, V> {
    entries: Mutex<Vec<(K, Arc<Slot<V>>)>>,
}

impl<K: PartialEq, V: Clone> Cache<K, V> {
    const fn new() -> Self {
        Cache {
            entries: Mutex::new(Vec::new()),
        }
    }

    /// The value of `key`, computed by `f` the first time.
    fn get(&self, key: K, f: impl FnOnce() -> V) -> V {
        let slot = {
            let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
            match entries.iter().find(|(k, _)| *k == key) {
                Some((_, s)) => Arc::clone(s),
                None => {
                    if entries.len() >= CAPACITY {
                        entries.remove(0);
                    }
                    let s = Arc::new(Slot {
                        value: OnceLock::new(),
                        computed: AtomicUsize::new(0),
                    });
                    entries.push((key, Arc::clone(&s)));
                    s
                }
            }
        };
        slot.value
            .get_or_init(|| {
                slot.computed.fetch_add(1, Ordering::Relaxed);
                f()
            })
            .clone()
    }

    /// Times the values of the keys matching `pick` were computed.
    fn computations(&self, pick: impl Fn(&K) -> bool) -> usize {
        let entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        entries
            .iter()
            .filter(|(k, _)| pick(k))
            .map(|(_, s)| s.computed.load(Ordering::Relaxed))
            .sum()
    }
}

type Loaded = Result<Arc<ImportedStructure>, Diagnostics>;
type ReducedKey = (SourceKey, usize, Vec<usize>);

static LOADS: Cache<SourceKey, Loaded> = Cache::new();
static REDUCTIONS: Cache<ReducedKey, Result<Arc<Reduced>, String>> = Cache::new();

/// [`ImportedStructure::from_files`] (or [`StructureParts::model`]), once per distinct
/// input.
pub fn load(source: &StructureSource) -> Result<ImportedStructure, Diagnostics> {
    let Some(key) = SourceKey::of(source) else {
        return from_source(source);
    };
    LOADS
        .get(key, || from_source(source).map(Arc::new))
        .map(|s| (*s).clone())
}

/// [`craig_bampton`] of the structure of `source` (`full`, as [`load`] gave it) to
/// `interface` and `modes` fixed-interface modes, once per distinct input; `Err` carries the
/// reduction's message.
pub fn reduce(
    source: &StructureSource,
    full: &ImportedStructure,
    interface: &[usize],
    modes: usize,
) -> Result<Reduced, String> {
    let run = || {
        craig_bampton(
            &full.stiffness,
            &full.mass,
            full.damping.as_ref(),
            interface,
            modes,
        )
        .map(Arc::new)
        .map_err(|e| e.to_string())
    };
    let value = match SourceKey::of(source) {
        Some(key) => REDUCTIONS.get((key, modes, interface.to_vec()), run),
        None => run(),
    };
    value.map(|r| (*r).clone())
}

/// How many times the structure of `f` (every file path as given) was read and how many
/// times it was reduced, over the entries still kept: what the cache saved can be counted.
pub fn computations(f: &MatrixFiles) -> (usize, usize) {
    let same = |k: &SourceKey| {
        let paths = [&f.mass, &f.stiffness, &f.nodes, &f.dofs];
        matches!(k, SourceKey::Files(k) if paths.iter().all(|p| k.files.iter().any(|(q, _)| q == *p)))
    };
    (
        LOADS.computations(same),
        REDUCTIONS.computations(|(k, _, _)| same(k)),
    )
}
