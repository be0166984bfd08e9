//! Reactive LiDAR avoiders usable onboard at 20-50 Hz (seeds 000, 001, 003).
