//! The exact CPU reference renderer (in progress).
