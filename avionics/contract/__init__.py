"""The output contract: every output of the DAA process declared once (issue 31).

- `zenoh`: key expressions, each payload's fields (type, unit, meaning, the range a receiver may check), the
  traffic batch's Arrow columns; avionics/io/payloads.py, io/traffic.py and the monitor's checks
  (monitor/schema.py) derive from it, and a test holds docs/zenoh.md's field tables to it.
- `mavlink`: what COLLISION, DAA_ADVISORY, DAA_BANDS and STATUSTEXT carry (avionics/io/encode.py builds them);
  a test holds docs/mavlink.md's tables and the generated dialect to it.
- `bands`: band kinds and regions (advisory/bands.py, the payloads, DAA_BANDS, the page and the terminal view).
- `advisory_csv`: the advisory CSV's columns (avionics/ports.py CsvOut).
- `fields`: what a field is, and the physical limits the fields use.

It imports only avionics.base: the stages may read it (advisory/bands.py takes its band kinds from here).
"""
