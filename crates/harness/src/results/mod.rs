//! What a run leaves behind: the rows and their writers ([`output`]: results.csv,
//! results.json, flushed row by row), the run's provenance ([`meta`]), the counter regression
//! check against a baseline ([`check`]) and the merge of shards' folders ([`merge`]).

pub mod check;
pub mod merge;
pub mod meta;
pub mod output;
