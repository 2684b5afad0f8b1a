"""Evaluation shells outside the flight package: what composes the onboard code with the SITL simulator.

cli             `demo`, `bench`, `evaluate`: added to the `avionics` console script (entry point avionics.commands)
demo            `avionics demo`: the onboard process and a SITL encounter as two processes on loopback
bench           `avionics bench`: end-to-end throughput and report-to-advisory latency
capacity_bench  `avionics bench --capacity`: capacity, latency, start-up and memory (issue 13's instrument)
flood_bench     link framing and flood measurements (docs/performance.md)
tracking_bench  microseconds per track update, against filterpy (docs/tracking.md)
monitor_bench   monitor throughput and page frame rate (docs/monitor.md)
monitor_sim     a simulated vehicle publishing on zenoh, for monitor tests, demos and fleets
reports/        the report commands behind the numbers and plots in docs/

Flight code (avionics) never imports this package or sitl; tests/test_layers.py checks it.
"""
