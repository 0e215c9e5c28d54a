//! What a run leaves behind: the rows and their writers ([`output`]: results.csv,
//! results.json, flushed row by row), the run's provenance ([`meta`]), the counter regression
//! check against a baseline ([`check`]), the merge of shards' folders ([`merge`]) and the
//! folder lock that keeps one writer per folder ([`lock`]).

pub mod check;
pub mod lock;
pub mod merge;
pub mod meta;
pub mod output;
