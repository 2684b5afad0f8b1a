"""`sitl` command line: list, live, replay."""

from __future__ import annotations

import argparse
import json
import sys

from avionics.cli import (ERRORS as FLIGHT_ERRORS, OneLineParser, call, check_output_file, port_number,
                          positive_seconds, seconds)
from avionics_sitl.impairments import PRESETS

ERRORS = FLIGHT_ERRORS + (("avionics_sitl.encounters", "ScenarioError", 2, ""),  # a bad encounter name or file: exit 2
                          ("avionics_sitl.live", "FeedServerError", 1, ""))  # --sbs/--beast cannot listen: exit 1


def _scenario(args):
    from avionics_sitl.encounters import load_scenario  # ScenarioError (exit 2) for a bad name or file

    return load_scenario(args.encounter, ownship=args.ownship, ownship_file=args.ownship_file, units=args.units,
                         gap_s=args.gap, progress=True if args.progress else None)


def cmd_list(args) -> int:
    from avionics_sitl.builtin import BUILTIN

    for name, build in sorted(BUILTIN.items()):
        scenario = build()
        print(f"{name:20s} {scenario.duration_s:6.0f} s  {len(scenario.intruders)} intruder(s)  "
              f"{scenario.description.splitlines()[0] if scenario.description else ''}")
    return 0


def cmd_replay(args) -> int:
    from avionics.config import load_config
    from avionics_sitl.replay import replay

    guidance = ["guidance.mode=execute", f"vehicle.profile={args.vehicle}"] if args.fly_guidance else []
    config = load_config(args.config, guidance + list(args.set) + ["zenoh.enabled=false"])
    for path, option in ((args.misses, "--misses"), (args.out, "--out")):
        if path:
            check_output_file(path, option)  # before the run, not after it
    progress = True if getattr(args, "progress", False) else None
    scenario = _scenario(args)
    if args.fly_guidance:  # the rows `avionics run --csv` writes, with the guidance's columns
        import contextlib

        from avionics.ports import CsvOut

        with open(args.out, "w", newline="") if args.out else contextlib.nullcontext(sys.stdout) as out:
            csv_out = CsvOut(out, {a.icao_address: a.name for a in scenario.intruders}, guidance=True)
            result = replay(scenario, config, PRESETS[args.noise], seed=args.seed, progress=progress,
                            fly_guidance=True, ports=[csv_out], firmware=args.autopilot)
    else:
        result = replay(scenario, config, PRESETS[args.noise], seed=args.seed, respond=args.fly_ras,
                        progress=progress, sensors=args.sensor, exact_sensors=args.noise == "none")
    if args.misses:
        result.write_misses_csv(args.misses)
    if args.out and not args.fly_guidance:  # (with --fly-guidance the rows were written as it flew)
        result.write_csv(args.out)
    elif not args.fly_guidance:
        import csv

        from avionics.contract.advisory_csv import CSV_COLUMNS

        writer = csv.DictWriter(sys.stdout, fieldnames=CSV_COLUMNS)
        writer.writeheader()
        writer.writerows(result.rows())
    return 0


def tcp_listen_address(text: str) -> tuple[str, int]:
    """`[HOST:]PORT` of a feed server; HOST 127.0.0.1 when left out (never another interface by default)."""
    host, sep, port = text.rpartition(":")
    if sep and not host:
        raise argparse.ArgumentTypeError(f"no host before ':' in {text!r} (use PORT or HOST:PORT)")
    return (host or "127.0.0.1"), port_number(port)


def _sensor_list(text: str) -> tuple[str, ...]:
    from avionics_sitl.sensor_feed import sensor_list

    try:
        return sensor_list(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def autopilot_mode_name(mode: int, autopilot: str) -> str:
    from avionics_sitl.guided_plane import mode_name

    return mode_name(mode, autopilot)


def cmd_live(args) -> int:
    from avionics_sitl.live import ScenarioClock, feed_servers, fly

    def show(received):
        msg = received.msg
        if msg.get_type() == "COLLISION":
            line = {"time_s": round(received.time_s, 2), "type": "COLLISION", "id": f"{msg.id:06X}",
                    "threat_level": msg.threat_level, "action": msg.action,
                    "time_to_minimum_delta": round(msg.time_to_minimum_delta, 2),
                    "horizontal_minimum_delta": round(msg.horizontal_minimum_delta, 1),
                    "altitude_minimum_delta": round(msg.altitude_minimum_delta, 1)}
        elif msg.get_type() == "STATUSTEXT":
            line = {"time_s": round(received.time_s, 2), "type": "STATUSTEXT", "text": msg.text}
        else:
            return
        print(json.dumps(line), flush=True)

    scenario = _scenario(args)
    if args.fly_guidance:  # the simulated ArduCopter obeys the guidance's commands (sitl/avionics_sitl/guided.py)
        from avionics.advisory.vehicle import load_vehicle
        from avionics.advisory.tables import ProfileError
        from avionics.base.params import ConfigError
        from avionics_sitl.guided_plane import default_firmware, simulated_autopilot
        from avionics_sitl.live import fly_guided

        try:
            vehicle = load_vehicle(args.vehicle)
        except ProfileError as exc:
            raise ConfigError(f"--vehicle: {exc}") from exc
        args.autopilot = args.autopilot or default_firmware(vehicle.name)
        copter = simulated_autopilot(vehicle, args.autopilot, scenario.ground_elevation_m)
        recording = fly_guided(scenario, args.connection, PRESETS[args.noise], copter, seed=args.seed,
                               start_s=args.start, duration_s=args.duration, on_receive=show)
        print(json.dumps({"sent": recording.sent, "received": len(recording.received),
                          "modes": [[round(t, 2), autopilot_mode_name(m, args.autopilot)] for t, m in copter.modes]}),
              file=sys.stderr)
        return 0
    end_s = scenario.duration_s if args.duration is None else min(scenario.duration_s, args.start + args.duration)
    clock = ScenarioClock(args.start)
    scans, sensor_events, publisher, session = [], [], None, None
    if set(args.sensor) - {"adsb"}:  # the ownship's radar / active surveillance (sitl/avionics_sitl/sensor_feed.py)
        from avionics_sitl.sensor_feed import mavlink_events, sensor_scans, simulated_sensors

        scans = sensor_scans(scenario, simulated_sensors(args.sensor, args.seed, exact=args.noise == "none"), end_s,
                             args.start)
        if args.sensor_link in ("mavlink", "both"):
            sensor_events = mavlink_events(scans)
    # listening before the link opens and the clock starts: a port in use is exit 1 before anything flies
    servers = feed_servers(scenario, PRESETS[args.noise], args.seed, clock, end_s, sbs=args.sbs, beast=args.beast)
    try:
        if scans and args.sensor_link in ("zenoh", "both"):
            from avionics.io.params import ZenohConfig
            from avionics.io.zenoh_bus import open_session
            from avionics_sitl.sensor_feed import ZenohSensorPublisher

            session = open_session(ZenohConfig(listen=(), connect=(args.zenoh_connect,)))  # ZenohBusError: exit 1
            publisher = ZenohSensorPublisher(session, scans, clock, args.zenoh_prefix, args.zenoh_vehicle)
            servers.append(publisher)
        for server in servers:
            server.start()  # sends nothing before the clock starts (fly starts it once the link is open)
        recording = fly(scenario, args.connection, PRESETS[args.noise], seed=args.seed, start_s=args.start,
                        duration_s=args.duration, on_receive=show,
                        adsb_vehicle="adsb" in args.sensor and not args.no_adsb_vehicle, clock=clock,
                        extra_events=sensor_events)
    finally:
        for server in servers:
            server.stop()  # also on Ctrl-C and errors: the listeners and every client connection are closed
        if session is not None:
            session.close()
    summary = {"sent": recording.sent, "received": len(recording.received),
               "collisions": len(recording.of_type("COLLISION"))}
    if scans:
        summary["sensor_measurements"] = sum(len(s.measurements) for s in scans)
    for server in servers:
        summary[server.sent_key] = server.sent
    print(json.dumps(summary), file=sys.stderr)
    return 0


def _vehicle_args(p) -> None:
    """--vehicle and --autopilot of the closed loop through the guidance (replay and live --fly-guidance)."""
    p.add_argument("--vehicle", default="multirotor", metavar="NAME",
                   help="with --fly-guidance: the vehicle profile flown (vehicle.profile; default multirotor)")
    p.add_argument("--autopilot", choices=("ardupilot", "px4", "arduplane"), default=None,
                   help="with --fly-guidance: the simulated autopilot's firmware: ArduCopter (GUIDED), PX4 "
                        "(OFFBOARD) or ArduPlane (GUIDED change-altitude/heading); default: ArduPlane for the "
                        "fixed-wing vehicle, ArduCopter for any other")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="sitl", description="Simulated ownship and ADS-B traffic over MAVLink.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the built-in encounters").set_defaults(func=cmd_list)

    def common(p):
        p.add_argument("encounter", help="built-in name (sitl list), scenario .toml, DAIDALUS .daa file, or an "
                                         "OpenSky/traffic trajectory table .csv or .parquet")
        p.add_argument("--noise", choices=sorted(PRESETS), default="default", help="ADS-B impairments")
        p.add_argument("--seed", type=int, default=0, help="random seed of the impairments")
        from avionics_sitl.tables import DEFAULT_GAP_S, UNITS

        t = p.add_argument_group("trajectory tables (docs/scenarios.md)")
        t.add_argument("--ownship", metavar="ICAO24", help="the table's aircraft that is ownship (or the one of "
                                                           "--ownship-file, if that holds several)")
        t.add_argument("--ownship-file", metavar="FILE", help="ownship from another table (one row: a fixed "
                                                              "point, hovering at speed 0)")
        t.add_argument("--units", choices=sorted(UNITS), help="unit convention when the column names are "
                                                             "ambiguous: opensky (m, m/s) or traffic (ft, kt, ft/min)")
        t.add_argument("--gap", type=positive_seconds, default=DEFAULT_GAP_S, metavar="S",
                       help=f"a silence longer than S seconds is a gap in an intruder's reports (default "
                            f"{DEFAULT_GAP_S:g})")
        t.add_argument("--progress", action="store_true",
                       help="progress bars on stderr while reading and replaying (default: only when stderr is "
                            "a terminal)")

    p = sub.add_parser("replay", help="fly an encounter in fast time through the onboard core; CSV of advisories")
    common(p)
    p.add_argument("--out", metavar="FILE.csv", help="write the advisory changes here (default: stdout)")
    p.add_argument("--fly-ras", action="store_true",
                   help="close the loop: ownship flies the RAs with the profile's response model")
    p.add_argument("--fly-guidance", action="store_true",
                   help="close the loop through the guidance stage (guidance.mode=execute): a simulated ArduCopter "
                        "flies the ownship path as its mission in AUTO and obeys the GUIDED commands")
    _vehicle_args(p)
    p.add_argument("--misses", metavar="FILE.csv",
                   help="write the true miss per intruder at horizontal CPA, without and with the RAs flown "
                        "(equal without --fly-ras or --fly-guidance; --fly-guidance adds hmd_flown_m)")
    p.add_argument("--config", metavar="FILE", help="onboard configuration TOML")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE", help="config override")
    p.add_argument("--sensor", type=_sensor_list, default=("adsb",), metavar="adsb|radar|active[,...]",
                   help="how the intruders are seen: adsb (ADSB_VEHICLE), radar, active (the ownship's DO-365 "
                        "Appendix Q sensors as DAA_SENSOR_MEASUREMENT; exactly and all round with --noise none); "
                        "without adsb no intruder broadcasts; not with --fly-ras or --fly-guidance (default: adsb)")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("live", help="fly an encounter in real time over MAVLink; print what comes back (JSON lines)")
    common(p)
    p.add_argument("--connection", default="udpout:127.0.0.1:14540",
                   help="connection string (default: where avionics run listens by default)")
    p.add_argument("--start", type=seconds, default=0.0, metavar="S", help="start at scenario time S")
    p.add_argument("--duration", type=seconds, metavar="S", help="fly S seconds (default: to the scenario's end)")
    p.add_argument("--fly-guidance", action="store_true",
                   help="a simulated ArduCopter flies the ownship path as its mission and obeys the guidance's "
                        "commands (avionics run with guidance.mode=execute); ownship and traffic on MAVLink only")
    _vehicle_args(p)
    f = p.add_argument_group("ground receiver feeds (docs/traffic-inputs.md): the same intruders, same clock and seed")
    f.add_argument("--sbs", type=tcp_listen_address, metavar="[HOST:]PORT",
                   help="serve SBS-1 BaseStation lines on TCP (as dump1090/readsb port 30003; HOST default 127.0.0.1)")
    f.add_argument("--beast", type=tcp_listen_address, metavar="[HOST:]PORT",
                   help="serve Beast binary frames on TCP (as dump1090/readsb port 30005; HOST default 127.0.0.1)")
    f.add_argument("--no-adsb-vehicle", action="store_true",
                   help="leave ADSB_VEHICLE out of the MAVLink schedule: the feeds are the only traffic source")
    s = p.add_argument_group("onboard sensors (docs/scenarios.md, \"Onboard sensors\"): how the intruders are seen")
    s.add_argument("--sensor", type=_sensor_list, default=("adsb",), metavar="adsb|radar|active[,...]",
                   help="adsb: ADSB_VEHICLE (and --sbs/--beast); radar, active: the ownship's DO-365 Appendix Q radar "
                        "and active surveillance measure the intruders (exactly with --noise none); without adsb no "
                        "intruder sends ADSB_VEHICLE (default: adsb)")
    s.add_argument("--sensor-link", choices=("mavlink", "zenoh", "both"), default="mavlink",
                   help="where the sensors' measurements go: DAA_SENSOR_MEASUREMENT on the MAVLink link, the zenoh "
                        "sensor topic, or both (default: mavlink)")
    s.add_argument("--zenoh-connect", default="tcp/127.0.0.1:7447", metavar="ENDPOINT",
                   help="with --sensor-link zenoh|both: the zenoh endpoint to connect to (default: where avionics run "
                        "listens)")
    s.add_argument("--zenoh-prefix", default="daa", metavar="PREFIX", help="zenoh.key_prefix (default: daa)")
    s.add_argument("--zenoh-vehicle", default="uav1", metavar="ID", help="vehicle.id (default: uav1)")
    p.set_defaults(func=cmd_live)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "fly_guidance", False) and args.func is cmd_live and (args.sbs or args.beast
                                                                           or args.no_adsb_vehicle):
        parser.error("--fly-guidance sends ownship and traffic on MAVLink only: not with --sbs, --beast, "
                     "--no-adsb-vehicle")
    if args.func is cmd_live and "adsb" not in args.sensor and (args.sbs or args.beast or args.no_adsb_vehicle):
        parser.error("--sbs, --beast and --no-adsb-vehicle are ADS-B: --sensor must include adsb")
    if (getattr(args, "fly_guidance", False) or getattr(args, "fly_ras", False)) and args.sensor != ("adsb",):
        parser.error("the simulated sensors measure the scenario's paths: --fly-ras and --fly-guidance serve traffic "
                     "as ADSB_VEHICLE only, not with --sensor")
    if getattr(args, "no_adsb_vehicle", False) and not (args.sbs or args.beast):
        parser.error("--no-adsb-vehicle needs --sbs or --beast (otherwise no traffic is sent at all)")
    return call("sitl", args.func, args, ERRORS)  # exit codes as avionics: 1 link, 2 configuration, scenario or file


if __name__ == "__main__":
    sys.exit(main())
