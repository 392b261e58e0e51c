//! Campaigns: many meshes, ray sets and tracers, split into shards that any batch scheduler
//! runs (a CI matrix, Slurm array jobs, GNU parallel), resumable, merged into one report.
//!
//! A campaign is data: a plan ([`plan`]: TOML or JSON naming meshes, scenes, ray sets,
//! tracers and reports) expands to work items with stable ids and estimated costs;
//! `--shard K/N` runs the items of one deterministic, cost-balanced part ([`shard`]); each
//! item ([`item`]) writes one typed JSON result into the output folder, whole or not at all
//! ([`run`]); `campaign merge` reads any set of shard folders of one plan into a
//! [`merge::Campaign`], which [`crate::report::campaign`] writes as Markdown, JSON and HTML.

pub mod item;
pub mod merge;
pub mod plan;
pub mod run;
pub mod shard;

pub use item::{ItemResult, RESULT_FORMAT};
pub use merge::{Campaign, merge};
pub use plan::{Item, ItemKind, Plan, load};
pub use run::{Manifest, RunOptions, RunSummary};
pub use shard::Shard;
