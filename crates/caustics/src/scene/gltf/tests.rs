//! Unit tests of the glTF loader on documents built in memory.
