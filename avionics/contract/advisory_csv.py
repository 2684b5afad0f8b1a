"""The advisory CSV (`sitl replay --out`, `avionics run --csv`): one row per advisory change, times to 0.01 s,
numbers to 0.001, unknown and infinite values empty (avionics/ports.py csv_row writes it). The columns carry the
zenoh advisory's fields of the same name (docs/zenoh.md, Advisory) but these three: `advisory` is `level`, `ra` is
`ra_words`, `name` is the scenario's name of the aircraft, else its callsign."""

from __future__ import annotations

CSV_COLUMNS = ("time_s", "intruder", "advisory", "ra", "ra_sense", "target_vertical_rate_mps", "name", "reason",
               "sensitivity_level", "range_m", "closure_rate_mps", "t_cpa_s", "hmd_m", "vmd_m", "range_tau_s",
               "mod_tau_s", "vertical_tau_s", "ra_separation_m", "alert_level", "alert_name", "ra_composite")
CSV_RENAMED = {"advisory": "level", "ra": "ra_words"}  # column -> the advisory field it carries
CSV_NAME_COLUMN = "name"

# With guidance (guidance.mode advise or execute) the CSV has these columns too: every row carries the guidance's
# decision of its step, and a change of the guidance's state is a row of its own (advisory `GUIDANCE`).
GUIDANCE_CSV_COLUMNS = ("guidance_state", "guidance_manoeuvre", "guidance_target_vertical_rate_mps",
                        "guidance_target_track_deg", "guidance_reason", "autopilot_mode")
GUIDANCE_ROW = "GUIDANCE"  # the `advisory` of a guidance state change's own row
