//! Placeholder: this stage is being written (see the issue tracker).
