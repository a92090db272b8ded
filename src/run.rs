//! Running a planned scene (being written).
