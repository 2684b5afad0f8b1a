"""`avionics monitor --tui`: the same picture in a terminal (rich), for an ssh session.

Keys (when stdin is a terminal): n / p next / previous vehicle, + / - range, t north-up / track-up, q quit.

With a DO-365 alerter the vehicle's guidance bands are shown as text under the display (a GUIDANCE BANDS panel):
per kind (track, ground speed, vertical speed, altitude, in deg, kt, fpm, ft) each region with its interval, in
the page's colours (daa-displays'), `STALE` when no bands came for `bands_stale_s`; advisories show the alerter's
level name (PREVENTIVE, CORRECTIVE, WARNING) where it differs from TCAS's.

Every string that comes from a payload or a key expression (vehicle and intruder ids, callsigns, levels, RA words,
reasons, warnings) goes to rich as a `Text`, which rich never parses for markup or emoji codes: a callsign `[/]`
is shown as `[/]` (as a plain `str` cell it would be markup, and a stray closing tag raises MarkupError).
"""

from __future__ import annotations

import math
import os
import select
import sys
import threading
import time

from rich import box
from rich.console import Console
from rich.layout import Layout
from rich.live import Live
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from avionics.contract.bands import BAND_KINDS
from avionics.base.units import FPM, FT, NM
from avionics.monitor.state import FleetState

# Band regions in the page's colours (NASA daa-displays, src/daa-displays/daa-utils.ts bandColors: FAR dashed
# yellow, MID yellow, NEAR red, RECOVERY dashed green; NONE is not drawn there, dim here)
BAND_STYLE = {"NONE": "dim", "FAR": "yellow underline", "MID": "bold yellow", "NEAR": "bold red",
              "RECOVERY": "bold green underline"}
# kind, label with display unit, SI units per display unit (avionics/contract/bands.py)
BAND_ROWS = tuple((k.name, f"{k.label} {k.display_unit}", k.per_display_unit) for k in BAND_KINDS)


def level_name(level, name) -> str:
    """The alerter's own name of the level where it differs from TCAS's (DO-365: PREVENTIVE, CORRECTIVE, WARNING)."""
    return str(name) if name and name != level else str(level)


# The monitor's own zenoh link (FleetState.zenoh_link, feed.py ZenohFeed.link_state) -> the header's light
ZENOH_LIGHTS = {"ok": ("ZENOH OK", "bold green"), "no_data": ("ZENOH NO DATA", "bold yellow"),
                "no_peer": ("ZENOH NO PEER", "bold red"), "down": ("ZENOH DOWN", "bold red")}


def zenoh_light(link: dict | None) -> tuple[str, str]:
    """(the light's words, its rich style); the counts of routers and peers when connected."""
    link = link or {}
    word, style = ZENOH_LIGHTS.get(link.get("state"), ("ZENOH ?", "dim"))
    if link.get("state") in ("ok", "no_data"):
        word += f" {link.get('routers', 0)}R/{link.get('peers', 0)}P"
    return word, style


def bands_text(bands: dict | None) -> Text:
    """The bands as text: one line per kind, each region with its interval in display units."""
    text = Text()
    if not bands:
        return text
    for kind, label, unit in BAND_ROWS:
        text.append(f"{label:8} ", style="grey70")
        intervals = bands.get(kind)
        if (bands.get("recovery") or {}).get(kind) is True:
            text.append("RECOVERY ", style=BAND_STYLE["RECOVERY"])
        if intervals is None:
            text.append("—")
        elif not intervals:
            text.append("no bands computed (ownship outside the range)", style="dim")
        for iv in intervals or ():
            region = str(iv["region"])
            text.append(f"{region} {round(iv['lower'] / unit)}–{round(iv['upper'] / unit)}",
                        style=BAND_STYLE.get(region, "grey50"))
            text.append("  ")
        text.append("\n")
    alerts = " · ".join(f"{i.get('intruder')} {i.get('alert_name') or i.get('alert_level')}"
                        for i in bands.get("intruders") or ())
    text.append(f"{'ALERTS':8} ", style="grey70")
    text.append(alerts or "—")
    return text

RANGES_NM = (0.5, 1, 2, 3, 6, 12, 20, 40, 80)
GLYPH = {"OTHER": "◇", "PROX": "◆", "TA": "●", "RA": "■"}
STYLE = {"OTHER": "cyan", "PROX": "bold cyan", "TA": "bold yellow", "RA": "bold red"}
RANK = {"RA": 0, "TA": 1, "PROX": 2, "OTHER": 3}


def _f(value, digits=0, scale=1.0) -> str:
    return "—" if value is None else f"{value / scale:.{digits}f}"


def _plain(value, style: str = "") -> Text:
    """Payload text for rich, shown as it is: a Text is not markup ("—" for none)."""
    return Text("—" if value is None or value == "" else str(value), style=style)


def _threat(t: dict) -> tuple:
    return (RANK.get(t["sym"], 3), t["tau_s"] if t["tau_s"] is not None else 1e6,
            t["range_m"] if t["range_m"] is not None else 1e9)


class TuiView:
    def __init__(self, state: FleetState, vehicle: str | None = None, range_nm: float = 6, north_up: bool = True):
        self.state = state
        self.vehicle = vehicle
        self.range_idx = RANGES_NM.index(range_nm) if range_nm in RANGES_NM else 4
        self.north_up = north_up

    # -- keys ----------------------------------------------------------------------------------------------
    def key(self, ch: str) -> bool:
        """Handle one key; False to quit."""
        ids = [v["id"] for v in self.state.fleet()]
        if ch == "q":
            return False
        if ch in "np" and ids:
            i = ids.index(self.vehicle) if self.vehicle in ids else 0
            self.vehicle = ids[(i + (1 if ch == "n" else -1)) % len(ids)]
        elif ch == "+":
            self.range_idx = min(len(RANGES_NM) - 1, self.range_idx + 1)
        elif ch == "-":
            self.range_idx = max(0, self.range_idx - 1)
        elif ch == "t":
            self.north_up = not self.north_up
        return True

    # -- rendering -----------------------------------------------------------------------------------------
    def render(self, width: int = 140, height: int = 44):
        if self.vehicle is None or self.vehicle not in self.state.vehicles:
            self.vehicle = self.state.default_vehicle()
        view, _ = self.state.view(self.vehicle)
        tracks = sorted(view.get("tracks", []), key=_threat)
        layout = Layout()
        log_h = min(12, max(6, height // 4))
        bands = view.get("bands")
        bands_h = 7 if bands else 0  # four kinds and the alerts, in a frame
        body_h = max(12, height - 3 - log_h - bands_h)
        parts = [Layout(self._header(view), size=3), Layout(name="body", size=body_h)]
        if bands:
            parts.append(Layout(self._bands(bands), size=bands_h))
        layout.split_column(*parts, Layout(self._log(view), size=log_h))
        radar_w = min(60, max(30, int(width * 0.36)))
        layout["body"].split_row(Layout(self._radar(view, tracks, radar_w, body_h - 2), size=radar_w + 4),
                                 Layout(self._table(tracks, body_h - 5)))
        return layout

    def _header(self, view) -> Panel:
        text = Text()
        text.append("DAA GROUND MONITOR  ", style="bold white")
        word, style = zenoh_light(view.get("zenoh"))
        text.append(f"[{word}]  ", style=style)
        for v in view.get("fleet", []):
            mark = "●" if v["online"] else "○" if v["online"] is False else "◌"
            style = "bold green" if v["online"] else "yellow" if v["online"] is False else "dim"
            label = f"{mark} {v['id']}" + (" OFFLINE" if v["online"] is False else "")  # Text.append: not markup
            if v["ra"]:
                label += " RA"
            elif v["ta"]:
                label += " TA"
            text.append(f"[{label}]" if v["id"] == self.vehicle else f" {label} ", style=style + (" reverse" if
                                                                                                v["id"] == self.vehicle else ""))
            text.append("  ")
        s = view.get("status") or {}
        o = view.get("ownship") or {}
        adv = s.get("advisories") or {}
        trk = "—" if o.get("track_deg") is None else f"{round(o['track_deg']) % 360:03d}"
        text.append(f"  SL {s.get('sensitivity_level') or '—'}  TA {adv.get('TA', '—')}  RA {adv.get('RA', '—')}  "
                    f"ALT {_f(o.get('alt_msl_m'), 0, FT)} ft  TRK {trk}°  "
                    f"{'NORTH UP' if self.north_up else 'TRACK UP'}  {RANGES_NM[self.range_idx]} NM", style="cyan")
        if s.get("warnings"):
            text.append("  " + " · ".join(str(w) for w in s["warnings"]), style="yellow")
        return Panel(text, box=box.SQUARE, padding=(0, 1))

    def _radar(self, view, tracks, w: int, h: int) -> Panel:
        """A character traffic display: ownship in the middle, a dotted ring at half range, symbols + tags."""
        grid = [[(" ", "")] * w for _ in range(h)]
        cx, cy = w // 2, h // 2
        ry = (h - 2) / 2
        rx = ry * 2.0  # terminal cells are about twice as tall as wide
        if rx > (w - 2) / 2:
            rx, ry = (w - 2) / 2, (w - 2) / 4
        own = view.get("ownship") or {}
        hdg = 0.0 if self.north_up else (own.get("track_deg") or 0.0)
        for deg in range(0, 360, 30):  # half-range ring, 12 dots
            a = math.radians(deg)
            x, y = cx + round(0.5 * rx * math.sin(a)), cy - round(0.5 * ry * math.cos(a))
            grid[y][x] = ("·", "dim")
        for deg in range(0, 360, 6):  # outer ring
            a = math.radians(deg)
            x, y = cx + round(rx * math.sin(a)), cy - round(ry * math.cos(a))
            if 0 <= y < h and 0 <= x < w:
                grid[y][x] = ("·", "grey35")
        nx, ny = cx + round(rx * math.sin(math.radians(-hdg))), cy - round(ry * math.cos(math.radians(-hdg)))
        if 0 <= ny < h and 0 <= nx < w:
            grid[ny][nx] = ("N", "bold cyan")
        grid[cy][cx] = ("▲" if not self.north_up else _arrow(own.get("track_deg")), "bold white")
        range_m = RANGES_NM[self.range_idx] * NM
        ch, sh = math.cos(math.radians(hdg)), math.sin(math.radians(hdg))
        for t in reversed(tracks):  # most threatening last: on top
            if t["e"] is None:
                continue
            e, n = t["e"] * ch - t["n"] * sh, t["e"] * sh + t["n"] * ch
            d = math.hypot(e, n) / range_m
            if d > 1.0:
                if t["sym"] not in ("TA", "RA"):
                    continue
                e, n = e / d, n / d
            x, y = cx + round(e / range_m * rx), cy - round(n / range_m * ry)
            if not (0 <= y < h and 0 <= x < w):
                continue
            style = STYLE[t["sym"]]
            grid[y][x] = (GLYPH[t["sym"]], style)
            label = (t["tag"] or "") + ("↑" if t["vs"] == "up" else "↓" if t["vs"] == "down" else "")
            for i, c in enumerate(label):
                if x + 1 + i < w:
                    grid[y][x + 1 + i] = (c, style)
        text = Text()
        for row in grid:
            for c, style in row:
                text.append(c, style=style)
            text.append("\n")
        title = _plain(f"{self.vehicle or '—'}" + (" OFFLINE" if view.get("online") is False else ""))
        ra = next((t for t in tracks if t["level"] == "RA"), None)
        subtitle = None
        if ra:
            name = level_name("RA", ra.get("alert_name"))
            words = ra["ra_words"] or (ra["ra_sense"] or "").upper() or ("RA" if name == "RA" else "")
            target = ra["target_vertical_rate_mps"]
            subtitle = Text(f" {name}" + (f" {words}" if words and words != name else "")
                            + (f" {target / FPM:+.0f} fpm " if target is not None else " "), style="bold white on red")
        elif any(t["level"] == "TA" for t in tracks):
            ta = max((t for t in tracks if t["level"] == "TA"), key=lambda t: t.get("alert_level") or 0)
            name = level_name("TA", ta.get("alert_name"))
            subtitle = Text(" TRAFFIC " + (f"{name} " if name != "TA" else ""), style="bold black on yellow")
        return Panel(text, title=title, subtitle=subtitle, box=box.ROUNDED,
                     border_style="yellow" if view.get("online") is False else "grey50", padding=(0, 1))

    def _bands(self, bands: dict) -> Panel:
        title = Text("GUIDANCE BANDS ")
        title.append_text(_plain(bands.get("alerter")))
        title.append(f"  t {_f(bands.get('time_s'), 1)} s")
        if bands.get("stale"):
            title.append(f"  STALE {round(bands.get('age_s') or 0)} s", style="bold yellow")
        return Panel(bands_text(bands), title=title, box=box.ROUNDED, padding=(0, 1),
                     border_style="yellow" if bands.get("stale") else "grey50")

    def _table(self, tracks, rows: int) -> Panel:
        table = Table(box=box.SIMPLE_HEAD, expand=False, pad_edge=False, header_style="bold grey70", padding=(0, 0))
        for name, justify, width in (("ID", "left", 13), ("CALLSIGN", "left", 8), ("SYM", "center", 3),
                                     ("RNG NM", "right", 6), ("BRG", "right", 3), ("REL ft", "right", 6),
                                     ("V/S", "center", 3), ("τ s", "right", 5), ("Pc", "right", 5),
                                     ("IMM", "left", 7), ("ADVISORY", "left", 12)):
            table.add_column(name, justify=justify, no_wrap=True, min_width=width)
        for t in tracks[:rows]:
            adv = level_name(t["level"], t.get("alert_name")) + (
                f" {t['ra_words'] or t['ra_sense'] or ''}" if t["level"] == "RA" else "")
            table.add_row(_plain(t["id"]), _plain(t["callsign"]), Text(GLYPH[t["sym"]], style=STYLE[t["sym"]]),
                          _f(t["range_m"], 2, NM), _f(t["bearing_deg"]),
                          "—" if t["rel_alt_m"] is None else f"{round(t['rel_alt_m'] / FT):+d}",
                          "↑" if t["vs"] == "up" else "↓" if t["vs"] == "down" else "", _f(t["tau_s"], 1),
                          _f(t["pc"], 3), _plain(t["imm"]),
                          Text(adv, style={"RA": "bold red", "TA": "bold yellow"}.get(t["level"], "dim")))
        note = f"{min(rows, len(tracks))} of {len(tracks)}" if len(tracks) > rows else f"{len(tracks)}"
        return Panel(table, title=f"TRACKS ({note})", box=box.ROUNDED, border_style="grey50", padding=(0, 0))

    def _log(self, view) -> Panel:
        table = Table(box=None, expand=True, pad_edge=False, show_header=True, header_style="bold grey70")
        for name in ("WALL", "t s", "INTRUDER", "CALLSIGN", "LEVEL", "RA", "TARGET fpm", "RNG NM", "τ s", "Pc",
                     "REASON", "FROM"):
            table.add_column(name, no_wrap=True)
        for e in reversed(view.get("log", [])[-8:]):
            table.add_row(time.strftime("%H:%M:%S", time.localtime(e["received_wall_s"])), _f(e["time_s"], 1),
                          _plain(e["intruder"]), _plain(e["callsign"]),
                          _plain(level_name(e["level"], e.get("alert_name")),
                                 style={"RA": "bold red", "TA": "bold yellow"}.get(e["level"], "")),
                          _plain(e["ra_words"] or e["ra_sense"]),
                          "—" if e["target_vertical_rate_mps"] is None else f"{e['target_vertical_rate_mps'] / FPM:+.0f}",
                          _f(e["range_m"], 2, NM), _f(e["tau_s"], 1), _f(e["pc"], 3), _plain(e["reason"]),
                          _plain(e["source"]))
        return Panel(table, title="ADVISORY LOG", box=box.ROUNDED, border_style="grey50", padding=(0, 0))


def _arrow(track_deg) -> str:
    if track_deg is None:
        return "▲"
    return "↑↗→↘↓↙←↖"[int(((track_deg + 22.5) % 360) // 45)]


def render_text(state: FleetState, vehicle: str | None = None, width: int = 140, height: int = 44) -> str:
    """One frame as plain text (tests, logs)."""
    console = Console(width=width, height=height, record=True, file=open(os.devnull, "w"), color_system=None)
    console.print(TuiView(state, vehicle).render(width, height), height=height)
    return console.export_text()


def run_tui(state: FleetState, vehicle: str | None = None, refresh_hz: float = 4.0, stop: threading.Event | None = None,
            console: Console | None = None) -> int:
    console = console or Console()
    view = TuiView(state, vehicle)
    stop = stop or threading.Event()
    keys = _KeyReader() if sys.stdin.isatty() else None
    try:
        with Live(console=console, screen=True, auto_refresh=False) as live:
            while not stop.is_set():
                state.expire()
                live.update(view.render(console.size.width, console.size.height), refresh=True)
                deadline = time.monotonic() + 1.0 / refresh_hz
                while time.monotonic() < deadline and not stop.is_set():
                    ch = keys.read(deadline - time.monotonic()) if keys else None
                    if ch is None:
                        if not keys:
                            time.sleep(max(0.0, deadline - time.monotonic()))
                        continue
                    if not view.key(ch):
                        stop.set()
                    break
    except KeyboardInterrupt:
        pass
    finally:
        if keys:
            keys.close()
    return 0


class _KeyReader:
    """Single keys from a terminal in cbreak mode, restored on close."""

    def __init__(self):
        import termios
        import tty

        self.fd = sys.stdin.fileno()
        self.saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)

    def read(self, timeout_s: float) -> str | None:
        ready, _, _ = select.select([self.fd], [], [], max(0.0, timeout_s))
        return os.read(self.fd, 1).decode(errors="ignore") if ready else None

    def close(self) -> None:
        import termios

        termios.tcsetattr(self.fd, termios.TCSADRAIN, self.saved)
