//! Ray batches. TODO(helper B).
