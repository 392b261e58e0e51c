//! Tracers rtdiff did not write, loaded at run time from a shared library that
//! implements the C ABI of `include/rtdiff_tracer.h` (`--tracer plugin:PATH`;
//! docs/plugins.md).
//!
//! [`load`] opens a library once per process (by canonical path), checks its
//! ABI version and symbols, and returns a [`PluginId`], a small copyable handle
//! that [`crate::backends::Backend::Plugin`] carries. Libraries are never
//! unloaded: a plugin's code may still be on a thread's stack when a scene is
//! dropped, and a process loads few of them. [`PluginTracer`] builds one of the
//! plugin's scenes over rtdiff's primitives and answers [`Tracer`] queries
//! through it, as the plugin returns them (the harness judges them, garbage
//! included); [`Checked`] is the same tracer for renders, where a hit that
//! names no primitive would have nothing to shade.

pub mod ffi;
pub mod tracer;

pub use tracer::{Checked, PluginBuffers, PluginTracer};

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::{Error, Result};

/// A loaded plugin: its library's entry points, name and features.
pub struct Plugin {
    /// The library as named on the command line.
    pub path: PathBuf,
    /// What `rtdiff_tracer_name()` returned.
    pub name: String,
    /// `rtdiff_tracer_features()`'s bits (`ffi::FEATURE_*`).
    pub features: u32,
    /// The file name, added to the label when another plugin loaded first has the same name.
    distinct: Option<String>,
    pub(crate) fns: ffi::Fns,
    // Kept open for the life of the process (see the module docs).
    _lib: libloading::Library,
}

impl Plugin {
    /// True when the plugin builds scenes with spheres.
    pub fn spheres(&self) -> bool {
        self.features & ffi::FEATURE_SPHERES != 0
    }

    /// The tracer's label in every report: `plugin:NAME`, or `plugin:NAME (FILE)` when a
    /// plugin loaded before it in this process has the same name (two builds of one library).
    pub fn label(&self) -> String {
        match &self.distinct {
            None => format!("plugin:{}", self.name),
            Some(file) => format!("plugin:{} ({file})", self.name),
        }
    }
}

/// A plugin loaded by [`load`], by its place in the process's table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PluginId(u32);

static LOADED: Mutex<Vec<(PathBuf, &'static Plugin)>> = Mutex::new(Vec::new());

impl PluginId {
    /// The plugin.
    pub fn plugin(self) -> &'static Plugin {
        LOADED.lock().expect("plugin table")[self.0 as usize].1
    }
}

impl serde::Serialize for PluginId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.plugin().label())
    }
}

impl<'de> serde::Deserialize<'de> for PluginId {
    fn deserialize<D: serde::Deserializer<'de>>(_: D) -> std::result::Result<Self, D::Error> {
        Err(serde::de::Error::custom("a plugin is chosen on the command line (--tracer plugin:PATH), not in a file"))
    }
}

/// Load the plugin at `path` (once per process): the library must exist, export
/// every function of `include/rtdiff_tracer.h` and report
/// [`ffi::ABI_VERSION`]. Errors name the file and what is wrong.
pub fn load(path: &Path) -> Result<PluginId> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, &e))?;
    if !meta.is_file() {
        return Err(Error::file(path, "a plugin must be a shared library file"));
    }
    let key = std::fs::canonicalize(path).map_err(|e| Error::io(path, &e))?;
    let mut table = LOADED.lock().expect("plugin table");
    if let Some(i) = table.iter().position(|(k, _)| *k == key) {
        return Ok(PluginId(i as u32));
    }
    // SAFETY: loading a library runs its initialisers; the user asked for this
    // library to be run as a tracer.
    let lib = unsafe { libloading::Library::new(&key) }.map_err(|e| {
        let detail = std::error::Error::source(&e).map(|s| format!(": {s}")).unwrap_or_default();
        Error::file(path, format!("cannot load the plugin ({e}{detail})"))
    })?;
    let fns = ffi::Fns::resolve(&lib).map_err(|sym| {
        Error::file(
            path,
            format!(
                "not an rtdiff tracer plugin: the symbol {sym} is missing (a plugin exports every function of \
                 include/rtdiff_tracer.h)"
            ),
        )
    })?;
    // SAFETY: the symbols are the ABI's functions, resolved from the library (kept open).
    let version = unsafe { (fns.abi_version)() };
    if version != ffi::ABI_VERSION {
        return Err(Error::file(
            path,
            format!(
                "the plugin speaks ABI version {version}, this rtdiff version {} (rebuild it against this \
                 include/rtdiff_tracer.h)",
                ffi::ABI_VERSION
            ),
        ));
    }
    // SAFETY: as above; the name is a NUL-terminated static string by the ABI (checked for NULL).
    let name = unsafe { ffi::c_string((fns.name)()) }
        .ok_or_else(|| Error::file(path, "rtdiff_tracer_name() returned NULL or text that is not UTF-8"))?;
    // SAFETY: as above.
    let features = unsafe { (fns.features)() };
    let distinct = table
        .iter()
        .any(|(_, p)| p.name == name)
        .then(|| path.file_name().map_or_else(|| path.display().to_string(), |f| f.to_string_lossy().into_owned()));
    let plugin: &'static Plugin =
        Box::leak(Box::new(Plugin { path: path.to_path_buf(), name, features, distinct, fns, _lib: lib }));
    table.push((key, plugin));
    Ok(PluginId(table.len() as u32 - 1))
}
