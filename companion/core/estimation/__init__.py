"""The filter and what it keeps: EKF-SLAM, data association, consistency, the landmark lifecycle, movers."""
