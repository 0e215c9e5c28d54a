//! Runs spread over machines: the partition of a run's work units into shards ([`shard`];
//! `run --shard K/N`, `scripts/slurm/`), whose folders [`tb_results::merge`] combines.

pub mod shard;
