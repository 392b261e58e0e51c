//! Measurement: clocks ([`clock`]), the builder x traversal benchmark
//! ([`bench`](mod@bench)), the interleaved race against Embree ([`race`]) and its
//! whole-render counterpart ([`render_race`]), the host's delay in starting
//! an idle pool thread ([`wake`]), and the
//! reports' measurements: the performance table ([`table`]), run time against
//! error ([`convergence`]) and numerical stability ([`stability`]). Each
//! returns a typed, serialisable report; `cli/` prints them and
//! [`crate::report`] turns them into tables, plots and pages.

pub mod bench;
pub mod clock;
pub mod convergence;
pub mod machine;
pub mod mitsuba;
pub mod mitsuba_python;
pub mod progress;
pub mod race;
pub mod render_race;
pub mod speed;
pub mod stability;
pub mod summary;
pub mod table;
pub mod wake;

pub use bench::{BenchOptions, BenchReport};
pub use race::{MeshRace, RaceOptions};
pub use render_race::{RenderRaceOptions, SceneRace};
