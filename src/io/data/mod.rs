//! Streaming readers and writers for run data.
