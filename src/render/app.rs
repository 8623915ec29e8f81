//! The aquarium window (`shoal run`).
