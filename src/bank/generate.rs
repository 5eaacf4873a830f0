//! Generating a bank: simulate every instance of the population in parallel (rayon, one level
//! above the simulator), write shard files atomically, resume after interruption, write the
//! manifest last and switch the bank's `CURRENT` pointer only when everything is in place.
//!
//! Directory layout of a bank `DIR`:
//!
//! ```text
//! DIR/CURRENT                      name of the complete version readers use (atomic rename)
//! DIR/v-<bank id>/shard-00000-of-00020.parquet
//! DIR/v-<bank id>/...
//! DIR/v-<bank id>/neighbours.bin   the instances' neighbour graph (bank::neighbours)
//! DIR/v-<bank id>/departures*.bin, roughness.json, out-of-round.bin   tables a pass needs
//!                                  (bank::derived; caches, checked as read)
//! DIR/v-<bank id>/layout.bin       where each column's values lie (bank::layout; plain banks)
//! DIR/v-<bank id>/manifest.json    written last, with every file's size and SHA-256
//! ```
//!
//! The bank id hashes everything that determines the bytes (calibration, N, seed, shard size,
//! storage format, generator and model revision), so a changed calibration builds a new version
//! beside the old one, and a rerun of the same arguments finds its own unfinished version.

use super::layout::{Derived, Layout, EARLIER_MAGIC, LAYOUT_FILE};
use super::neighbours::{cell_weights, in_metric_of, neighbour_graph, NEIGHBOURS_FILE};
use super::observer::GenerateObserver;
use super::population::Population;
use super::schema::{
    bank_id, bank_metadata_text, calibration_sha256, open_shard, sensor_axes, sha256_hex,
    shard_matches, BankMetadata, Manifest, ManifestAux, ManifestFile, Parameters, ShardInfo,
    FORMAT_VERSION, MODEL_REVISION,
};
pub use super::schema::{shard_file_name, CURRENT, MANIFEST};
use super::simulate::simulate_rows;
use super::writer::{write_shard, StorageFormat};
use super::BankError;
use crate::model::{CheckedCalibration, Record, Simulator};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateOptions {
    /// Instances in the whole bank.
    pub instances: usize,
    /// Population seed (0: plain Hammersley).
    pub seed: u64,
    /// Instances per shard file (the unit of resumable work).
    pub shard_size: usize,
    /// Only this machine's part: `(i, n)` takes shard files `[i·F/n, (i+1)·F/n)` of the F files.
    pub machine_shard: Option<(usize, usize)>,
    /// Encoding and compression.
    pub format: StorageFormat,
    /// When false, missing shard files are an error instead of being simulated (`bank merge`).
    pub simulate_missing: bool,
    /// Also build the tables a pass needs ([`super::derived`]) before `CURRENT` points at the
    /// version (the command line always does; a study's or a test's bank may leave them to the
    /// first pass that needs one).
    pub tables: bool,
}

/// What a generate call did.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// `CURRENT` already names a complete bank of these arguments; nothing was simulated.
    UpToDate {
        /// The version directory.
        version: PathBuf,
        /// Whether files a newer wheelflat stores beside the shards (neighbour graph, column
        /// layout) were added to it.
        upgraded: bool,
    },
    /// The bank is complete and `CURRENT` points at it.
    Complete {
        /// The version directory.
        version: PathBuf,
        /// Instances simulated by this call.
        simulated: usize,
        /// Instances kept from an earlier, interrupted run.
        resumed: usize,
    },
    /// This machine's shard files are written; the bank is completed by `bank merge`.
    ShardDone {
        /// The version directory.
        version: PathBuf,
        /// Instances simulated by this call.
        simulated: usize,
        /// Shard files written or found by this call.
        files: usize,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> BankError + '_ {
    move |source| BankError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes bytes atomically ([`crate::atomic::write_atomically`]).
pub(crate) fn write_file_atomically(path: &Path, bytes: &[u8]) -> Result<(), BankError> {
    crate::atomic::write_atomically(path, bytes).map_err(io_err(path))
}

/// The neighbour graph of the population's instances, built from the parameters exactly as
/// the shards store them; over a folded bank's instances as it reads them (every stored
/// instance at each whole-bay shift, [`super::reader::Bank::instances`]).
fn population_graph(cal: &CheckedCalibration, opts: &GenerateOptions) -> Vec<u32> {
    let population = Population::new(&cal.stored_population(), opts.instances, opts.seed);
    let mut p = Parameters::default();
    for i in 0..opts.instances {
        let s = population.instance(i);
        p.instance.push(i as u32);
        p.length_mm.push(s.length_mm);
        p.depth_mm.push(s.depth_mm);
        p.curvature_mm.push(s.curvature_mm);
        p.impact_position_m.push(s.impact_position_m);
        p.flat_wheel
            .push(s.wheel.unwrap_or(cal.vehicle.flat_wheel).index() as u8);
    }
    if cal.population.fold_to_one_bay {
        p = super::fold::expand(p, cal);
    }
    neighbour_graph(&p, &cal.population)
}

/// Writes a file beside the shards atomically; its manifest entry.
fn write_aux(version: &Path, name: &str, bytes: &[u8]) -> Result<ManifestAux, BankError> {
    write_file_atomically(&version.join(name), bytes)?;
    Ok(ManifestAux {
        name: name.into(),
        bytes: bytes.len() as u64,
        sha256: sha256_hex(bytes),
    })
}

/// Writes the version's `neighbours.bin` atomically; its manifest entry.
fn write_neighbours(
    version: &Path,
    id: &str,
    cal: &CheckedCalibration,
    opts: &GenerateOptions,
) -> Result<ManifestAux, BankError> {
    let bytes = super::neighbours::encode(
        id,
        cell_weights(&cal.population),
        &population_graph(cal, opts),
    );
    write_aux(version, NEIGHBOURS_FILE, &bytes)
}

/// The version's `layout.bin` ([`super::layout`]) from its shard files (`files`, in manifest
/// order), written atomically; its manifest entry, or `None` for a bank stored so that no
/// layout applies (compressed or byte-stream-split).
fn write_layout(
    version: &Path,
    id: &str,
    files: &[ManifestFile],
) -> Result<Option<ManifestAux>, BankError> {
    let derived: Vec<(Derived, Option<String>)> = files
        .par_iter()
        .enumerate()
        .map(|(i, f)| {
            let path = version.join(&f.name);
            let (bytes, meta, _) = open_shard(&path)?;
            let text = (i == 0)
                .then(|| bank_metadata_text(&path, meta.metadata().file_metadata()))
                .transpose()?;
            Ok((super::layout::derive(&path, &bytes, &meta)?, text))
        })
        .collect::<Result<_, BankError>>()?;
    let mut shards = Vec::with_capacity(files.len());
    let mut widths: Option<Vec<u8>> = None;
    let mut metadata_json = String::new();
    for (derived, text) in derived {
        let Derived::Layout(shard, w) = derived else {
            return Ok(None);
        };
        if widths.as_ref().is_some_and(|first| *first != w) {
            return Ok(None);
        }
        widths = Some(w);
        shards.push(shard);
        if let Some(t) = text {
            metadata_json = t;
        }
    }
    let layout = Layout {
        bank_id: id.to_string(),
        metadata_json,
        widths: widths.unwrap_or_default(),
        shards,
    };
    write_aux(version, LAYOUT_FILE, &layout.encode()).map(Some)
}

/// A complete version written before the graph or the layout was stored (or with a graph of
/// another metric, a layout of an earlier format) gets them now: the files, then the manifest
/// rewritten atomically with their entries (readers see the old or the new manifest, and
/// either describes files that are in place). Returns whether anything was added.
fn add_missing_aux(
    version: &Path,
    cal: &CheckedCalibration,
    opts: &GenerateOptions,
) -> Result<bool, BankError> {
    let mut manifest = super::version::read_manifest(version)?;
    let mut added = false;
    // A graph searched in another metric (the earlier, unstretched format, or other axis
    // weights) is replaced too; a damaged one stays, for `bank verify` to report.
    let other_metric = manifest.neighbours.as_ref().is_some_and(|aux| {
        super::version::read_neighbours(
            version,
            aux,
            &manifest.bank_id,
            manifest.instances * cal.fold_factor(),
        )
        .is_ok_and(|g| !in_metric_of(g.weights, &cal.population))
    });
    if manifest.neighbours.is_none() || other_metric {
        manifest.neighbours = Some(write_neighbours(version, &manifest.bank_id, cal, opts)?);
        added = true;
    }
    // A layout of an earlier format (without checksums) is replaced; any other layout stays
    // as it is (a damaged one is for `bank verify` to report, not for this to paper over).
    let earlier_format = manifest.layout.as_ref().is_some_and(|aux| {
        std::fs::read(version.join(&aux.name)).is_ok_and(|b| b.starts_with(EARLIER_MAGIC))
    });
    if manifest.layout.is_none() || earlier_format {
        manifest.layout = write_layout(version, &manifest.bank_id, &manifest.files)?;
        added |= manifest.layout.is_some();
    }
    if added {
        let json = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
        write_file_atomically(&version.join(MANIFEST), json.as_bytes())?;
    }
    Ok(added)
}

/// The bank id of a generate call with these arguments.
fn id_for(cal: &CheckedCalibration, opts: &GenerateOptions) -> String {
    bank_id(
        cal,
        opts.instances,
        opts.seed,
        opts.shard_size,
        &opts.format.name(),
    )
}

/// The version directory a generate call with these arguments uses.
pub fn version_dir(out: &Path, cal: &CheckedCalibration, opts: &GenerateOptions) -> PathBuf {
    out.join(format!("v-{}", id_for(cal, opts)))
}

/// Generates (or resumes, or confirms) a bank in `out`. Runs on the current rayon pool.
pub fn generate(
    cal: &CheckedCalibration,
    out: &Path,
    opts: &GenerateOptions,
    observer: &dyn GenerateObserver,
) -> Result<Outcome, BankError> {
    if opts.instances == 0 || opts.shard_size == 0 {
        return Err(BankError::Empty);
    }
    if opts.instances > u32::MAX as usize {
        return Err(BankError::TooManyInstances {
            instances: opts.instances,
        });
    }
    cal.check_fold()?;
    // One writer at a time (the tasks of a job array share the lock): taken before anything
    // is looked at, held to the end.
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    let access = if opts.machine_shard.is_some() {
        super::lock::Access::Shared
    } else {
        super::lock::Access::Exclusive
    };
    let _lock = super::lock::lock(out, access)?;
    let id = id_for(cal, opts);
    let version_name = format!("v-{id}");
    let version = out.join(&version_name);
    let current_path = out.join(CURRENT);
    if opts.machine_shard.is_none() {
        // An unreadable CURRENT is no reason not to build: it is replaced when the bank is.
        let current = super::version::read_current(out).ok().flatten();
        if current.as_ref().is_some_and(|c| c.version == version)
            && version.join(MANIFEST).is_file()
        {
            let mut upgraded = add_missing_aux(&version, cal, opts)?;
            if opts.tables {
                upgraded |= super::derived::build(&version, observer)? > 0;
            }
            // CURRENT states the manifest's hash (rewritten after the manifest, if it changed,
            // or if CURRENT predates the hash).
            let manifest = std::fs::read(version.join(MANIFEST)).map_err(io_err(&version))?;
            let text = super::version::current_text(&version_name, &manifest);
            if std::fs::read_to_string(&current_path).ok().as_deref() != Some(text.as_str()) {
                write_file_atomically(&current_path, text.as_bytes())?;
                upgraded = true;
            }
            return Ok(Outcome::UpToDate { version, upgraded });
        }
    }
    std::fs::create_dir_all(&version).map_err(io_err(&version))?;

    let count = opts.instances.div_ceil(opts.shard_size);
    let files: Vec<usize> = match opts.machine_shard {
        None => (0..count).collect(),
        Some((i, n)) => {
            if n == 0 || i >= n {
                return Err(BankError::Shard { index: i, count: n });
            }
            (i * count / n..(i + 1) * count / n).collect()
        }
    };
    // Leftovers of an interrupted run: temporary files are never complete. A task of a job
    // array removes only those of its own shard files (its neighbours may be writing theirs).
    let own: Vec<String> = files
        .iter()
        .map(|&f| format!(".{}.tmp-", shard_file_name(f, count)))
        .collect();
    for entry in std::fs::read_dir(&version).map_err(io_err(&version))? {
        let entry = entry.map_err(io_err(&version))?;
        let name = entry.file_name().to_string_lossy().to_string();
        let mine = opts.machine_shard.is_none() || own.iter().any(|p| name.starts_with(p));
        if crate::atomic::is_temporary(&name) && mine {
            std::fs::remove_file(entry.path()).map_err(io_err(&entry.path()))?;
        }
    }
    let shard_info = |index: usize| {
        let first = index * opts.shard_size;
        ShardInfo {
            index,
            count,
            first_instance: first,
            rows: opts.shard_size.min(opts.instances - first),
        }
    };
    // A folded bank is simulated with its stored pads and population (the calibration's own
    // otherwise); its metadata keeps the calibration as given.
    let stored = cal.stored();
    let simulator = Simulator::new(&stored)?;
    let axes_now = sensor_axes(&stored);
    let flat_free = simulator.run(None, Record::default())?;
    let flat_free_kn = axes_now
        .iter()
        .enumerate()
        .map(|(s, a)| {
            flat_free
                .window(s, a.first_sample, a.samples)
                .iter()
                .map(|v| (v / 1e3) as f32)
                .collect()
        })
        .collect();
    let base_meta = BankMetadata {
        format_version: FORMAT_VERSION,
        generator: format!("wheelflat {}", env!("CARGO_PKG_VERSION")),
        model_revision: MODEL_REVISION,
        bank_id: id.clone(),
        calibration_sha256: calibration_sha256(cal),
        calibration: cal.document().clone(),
        sampling: "hammersley: ((i+1/2)/N, phi2(i), phi3(i), phi5(i)) -> (L, d, c/min(c_hi, d/2), X_p); seed>0: Cranley-Patterson shift of the last three".into(),
        instances: opts.instances,
        seed: opts.seed,
        shard_size: opts.shard_size,
        shard: shard_info(0),
        sensors: axes_now,
        force_unit: "kN".into(),
        flat_free_kn,
    };

    // Which files are already complete (renamed into place only when whole, and their footer
    // names this bank)?
    let mut missing = Vec::new();
    let mut resumed = 0;
    for &f in &files {
        let path = version.join(shard_file_name(f, count));
        let info = shard_info(f);
        if path.is_file() && shard_matches(&path, &base_meta, &info).is_ok() {
            resumed += info.rows;
        } else {
            missing.push(f);
        }
    }
    if !missing.is_empty() && !opts.simulate_missing {
        let names: Vec<String> = missing.iter().map(|&f| shard_file_name(f, count)).collect();
        return Err(BankError::Incomplete {
            dir: version,
            missing: names,
        });
    }
    let to_simulate: usize = missing.iter().map(|&f| shard_info(f).rows).sum();
    observer.started(to_simulate, resumed);

    let population = Population::new(&stored.population, opts.instances, opts.seed);
    let simulator = if missing.is_empty() {
        None
    } else {
        Some(Simulator::new(&stored)?)
    };
    let axes = &base_meta.sensors;
    for &f in &missing {
        let sim = simulator
            .as_ref()
            .expect("a simulator exists when files are missing");
        let info = shard_info(f);
        let rows = simulate_rows(sim, cal, &population, axes, &info, observer)?;
        let name = shard_file_name(f, count);
        let path = version.join(&name);
        let tmp = crate::atomic::temporary_sibling(&path);
        let meta = BankMetadata {
            shard: info,
            ..base_meta.clone()
        };
        if let Err(e) = write_shard(&tmp, &meta, &rows, opts.format) {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        std::fs::rename(&tmp, &path).map_err(io_err(&path))?;
        observer.file_written(&name);
    }

    if opts.machine_shard.is_some() {
        return Ok(Outcome::ShardDone {
            version,
            simulated: to_simulate,
            files: files.len(),
        });
    }

    // Every file is in place: manifest last, then the pointer.
    let mut entries = Vec::with_capacity(count);
    for f in 0..count {
        let name = shard_file_name(f, count);
        let path = version.join(&name);
        let bytes = std::fs::read(&path).map_err(io_err(&path))?;
        let info = shard_info(f);
        entries.push(ManifestFile {
            name,
            first_instance: info.first_instance,
            rows: info.rows,
            bytes: bytes.len() as u64,
            sha256: sha256_hex(&bytes),
        });
    }
    let neighbours = write_neighbours(&version, &id, cal, opts)?;
    let layout = write_layout(&version, &id, &entries)?;
    let manifest = Manifest {
        format_version: FORMAT_VERSION,
        bank_id: id,
        generator: base_meta.generator.clone(),
        calibration_sha256: base_meta.calibration_sha256.clone(),
        instances: opts.instances,
        files: entries,
        neighbours: Some(neighbours),
        layout,
    };
    let json = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
    write_file_atomically(&version.join(MANIFEST), json.as_bytes())?;
    // The tables a pass needs, before the pointer: a first pass finds them.
    if opts.tables {
        super::derived::build(&version, observer)?;
    }
    write_file_atomically(
        &current_path,
        super::version::current_text(&version_name, json.as_bytes()).as_bytes(),
    )?;
    Ok(Outcome::Complete {
        version,
        simulated: to_simulate,
        resumed,
    })
}
