//! The command line's error, [`CliError`]: what failed, and the message `hapticgen` prints on
//! standard error before it exits with code 1.
//!
//! Each variant's `Display` is that message, as the commands have always printed it (the tests
//! of `targets/host/tests/` match it): most start with `error: `, a model's diagnostics are the
//! code generator's `error: FILE:LINE:COL: …` lines. Steps of the host library that report a
//! `String` keep it, wrapped in the variant that says which kind of step failed.

use std::fmt;
use std::path::PathBuf;

use hapticgen_codegen::Diagnostics;

/// Why a command failed.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A model file (or the model `import-urdf` wrote) that does not load: the code
    /// generator's diagnostics, with file, line and column.
    #[error("{0}")]
    Model(#[from] Diagnostics),
    /// A model that loads but that `check` refuses: its virtual wall is unstable, or it is
    /// implausible as a device (gravity against the drives, masses against sizes…).
    #[error("{0}")]
    Refused(Diagnostics),
    /// A value the command line's parser accepted but the command refuses: a count, a range,
    /// an option that needs another or excludes one (the message without its `error: `).
    #[error("error: {0}")]
    Usage(String),
    /// A file that could not be read, created or written.
    #[error("error: {op}{}: {source}", path.display())]
    File {
        /// What was done to the file.
        op: FileOp,
        /// The file.
        path: PathBuf,
        /// Why it failed.
        #[source]
        source: std::io::Error,
    },
    /// The CSV log of `connect --log` that could not be created or written.
    #[error("error: {}: {source}", path.display())]
    Log {
        /// The log file.
        path: PathBuf,
        /// Why it failed.
        #[source]
        source: csv::Error,
    },
    /// `new`: the template's options do not make a rig, or the file could not be written.
    #[error("error: {0}")]
    Template(#[from] crate::template::TemplateError),
    /// `report`: the design figures could not be computed or written.
    #[error("error: {0}")]
    Design(#[from] crate::design::DesignError),
    /// `eval`: the derived quantities are not valid at the state (the loops do not close, a
    /// value is not finite), or could not be written as JSON (the message without `error: `).
    #[error("error: {0}")]
    Evaluation(String),
    /// `export-urdf`: the model cannot be written as URDF (the reason without `error: `).
    #[error("error: {}: {reason}", model.display())]
    Export {
        /// The model file.
        model: PathBuf,
        /// Why not.
        reason: String,
    },
    /// An input other than a model that could not be loaded: a scene, a mesh, a run to
    /// replay (the library's message).
    #[error("{0}")]
    Input(String),
    /// Setting up or running a simulation, or writing its trace, figures and reports: the
    /// closed loop of `simulate`, `pil` (its image and QEMU too), `contact`, `paper`,
    /// `faults`, `zwidth` (the library's message).
    #[error("{0}")]
    Simulation(String),
    /// `excite`, `identify` and `simulate --scenario excite`: the identification's steps
    /// (the library's message).
    #[error("{0}")]
    Identification(String),
    /// `connect`: the link to the device, or what the device answered (the library's
    /// message).
    #[error("{0}")]
    Link(String),
    /// Checks that ran and failed: a contact scenario's, `pil`'s fault tests and comparison
    /// with `simulate`, the link's safety rules; the failed rows or their count.
    #[error("{0}")]
    Verdict(String),
}

impl CliError {
    /// The process's exit code for this error: 1 (2 is clap's, for a command line it cannot
    /// parse).
    pub fn exit_code(&self) -> u8 {
        1
    }

    /// A [`CliError::File`] error of `op` on `path`, for `map_err`.
    pub fn file(op: FileOp, path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> CliError {
        let path = path.into();
        move |source| CliError::File { op, path, source }
    }
}

/// What was being done to a file when [`CliError::File`] happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileOp {
    /// Reading it (`error: cannot read PATH: …`).
    Read,
    /// Creating it, a directory (`error: cannot create PATH: …`).
    Create,
    /// Writing it (`error: cannot write PATH: …`).
    Write,
    /// Writing an output the message names by its path only (`error: PATH: …`).
    Save,
}

impl fmt::Display for FileOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileOp::Read => "cannot read ",
            FileOp::Create => "cannot create ",
            FileOp::Write => "cannot write ",
            FileOp::Save => "",
        })
    }
}
