//! The shared oracle suite. TODO(helper B).
