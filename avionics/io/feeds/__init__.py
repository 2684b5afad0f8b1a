"""Traffic sources beside the MAVLink link: ADS-B receivers' outputs (SBS-1 BaseStation text, readsb/dump1090
aircraft.json, Beast binary) -> validated IntruderReports with each source's own accuracy, clock and counters.

    params.py      [traffic] section: per-source default accuracy, polling, reconnect, queue
    clock.py       ReceiverClock: receiver timestamps -> our loop clock (lower envelope of receipt - receiver time)
    aircraft.py    Observation (what one message says of one aircraft) and AircraftMerge (per-address merge ->
                   IntruderReport, with the MAVLink path's plausibility checks, avionics/io/checks.py)
    sbs.py         SBS-1 BaseStation lines -> Observations
    readsb_json.py readsb/dump1090 aircraft.json documents -> Observations
    source.py      a reader thread per feed (reconnect with backoff, bounded queue), spec parsing, the loop's
                   FeedSet and the wrapping TrafficSource

docs/traffic-inputs.md describes the formats, the field mapping, clock alignment, counters and reconnection."""
