"""``pndiss simulate``: write a capture of an IO controller and reference encoders, with ground truth."""
from __future__ import annotations

import argparse
import sys


def _scenario_help() -> str:
    from ..sim.scenarios import SCENARIOS
    return "; ".join(f"{n}: {c.help}" for n, c in SCENARIOS.items())


def add_parser(sub) -> None:
    from ..sim.model import PROFILE_TELEGRAMS
    from ..sim.scenarios import INJECTIONS, SCENARIOS

    p = sub.add_parser(
        "simulate", help="write a pcapng of a PLC and PROFIdrive encoders, with fault injection and ground truth",
        description="Write a pcapng of a complete PROFINET session between an IO controller and one or more "
                    "encoders (DCP, LLDP, Connect, records, parameter access, cyclic telegrams), plus "
                    "<name>.expected.json with the injected faults and expected decode facts. "
                    "Same arguments and seed give a byte-identical file.",
        epilog="scenarios: " + _scenario_help() + ". injectable rules: " + ", ".join(sorted(INJECTIONS))
               + " (docs/simulate.md says why the others are not).",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenario", default=None, choices=sorted(SCENARIOS), metavar="NAME",
                   help="one of: " + ", ".join(SCENARIOS) + " (default: the scenario the injected faults "
                        "need, else startup)")
    p.add_argument("--profile", default="generic", choices=sorted(PROFILE_TELEGRAMS), metavar="VENDOR",
                   help="device profile: " + ", ".join(PROFILE_TELEGRAMS) + " (default: generic)")
    p.add_argument("--telegram", type=int, default=81, metavar="N",
                   help="telegram: 81-84 (all), 860 (scancon, hohner, psm, generic), 86-89/100/101 (psm only)")
    p.add_argument("--cycle-time", default="1", metavar="MS[,MS...]", dest="cycle_ms",
                   help="IO cycle in ms: 0.25, 0.5, 1, 2, 4 ... (send clock x reduction ratio; default 1); "
                        "a comma list gives one per encoder")
    p.add_argument("--drift-ppm", type=float, default=50.0, metavar="PPM",
                   help="each clock (controller, every device) runs off by up to +-PPM (default 50): the order "
                        "of setpoint and actual frames drifts over time; 0 with --jitter-us 0: fixed order")
    p.add_argument("--jitter-us", type=float, default=20.0, metavar="US",
                   help="send-time jitter of cyclic frames, +-US (default 20, at most a quarter cycle)")
    p.add_argument("--irt", action="store_true",
                   help="isochronous RT_CLASS_3 (frame IDs 0x0100..., default cycle 0.25 ms): one synchronised "
                        "clock, no drift or jitter")
    p.add_argument("--io-devices", type=int, default=0, metavar="N",
                   help="ordinary IO devices (8 digital inputs / 8 digital outputs) with their own DCP, Connect "
                        "and cyclic frames on the same wire (default 0, max 16)")
    p.add_argument("--param-polls", type=float, default=0.0, metavar="MS", dest="param_polls_ms",
                   help="per encoder a PROFIdrive base-mode parameter read (P964, P965, P979 in turn) every MS ms "
                        "while the shaft turns, as an HMI polls (at least 10; default 0: none)")
    p.add_argument("--it-traffic", type=float, default=0.0, metavar="FPS", dest="it_fps",
                   help="IT frames per second on the segment: OPC UA over TCP, SNMP polls, ARP, mDNS, ICMP "
                        "(default 0: none, at most 100000)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--cycles", type=int, metavar="N", help="number of IO cycles (default 2000)")
    g.add_argument("--duration", type=float, metavar="S", help="cyclic run in seconds")
    p.add_argument("--encoders", type=int, default=1, metavar="N", help="number of encoders (default 1, max 16)")
    p.add_argument("--inject", action="append", default=[], metavar="RULE_ID[@CYCLE]",
                   help="break one catalogue rule (repeatable); CYCLE defaults to half-way")
    p.add_argument("--startup", default="realistic", choices=("realistic", "tidy"),
                   help="realistic (default): cyclic frames from the Connect on with IOPS BAD / ProviderState "
                        "STOP, records, PrmEnd, ApplicationReady, then GOOD; tidy: cyclic data only after "
                        "PrmEnd, GOOD from the first frame (the simulator's old start-up)")
    p.add_argument("--records", default="multiplewrite", choices=("multiplewrite", "plain"),
                   help="start-up records in one MultipleWrite (index 0xE040, as S7 controllers do; default) "
                        "or as plain writes")
    p.add_argument("--good-before-prmend", action="store_true",
                   help="the device sends GOOD data from its first frame and 0xBF00 is written a few cycles "
                        "after the Connect response, before PrmEnd")
    p.add_argument("--restart", type=int, metavar="CYCLE",
                   help="release encoder 1's AR at this data-exchange cycle and, after a silence, connect again "
                        "(new AR UUID, records, PrmEnd, ApplicationReady)")
    p.add_argument("--restart-scaling", metavar="KEY=VALUE[,...]", default="",
                   help="0xBF00 values of the second AR: mupr, tmr, direction, velocity_unit "
                        "(e.g. mupr=4096,tmr=16777216,direction=1); needs --restart")
    p.add_argument("--restart-mode", choices=("release", "abort"), default="release",
                   help="how the first AR ends: release (IODReleaseReq, default) or abort (ERR-RTA-PDU from the "
                        "controller)")
    p.add_argument("--restart-gap", type=float, default=200.0, metavar="MS",
                   help="silence between the Release and the new Connect (default 200 ms)")
    p.add_argument("--capture-loss", type=float, default=0.0, metavar="RATE",
                   help="share of cyclic frames lost at the capture point, 0..0.5 (seeded; never a frame that "
                        "carries an injected fault); the sidecar lists each gap in capture_gaps")
    m = p.add_mutually_exclusive_group()
    m.add_argument("--start-mid-session", type=int, metavar="CYCLE",
                   help="the capture starts at this data-exchange cycle: no DCP, Connect or records in it")
    m.add_argument("--start-mid-session-s", type=float, metavar="S", dest="start_mid_s",
                   help="the same in seconds after the start of data exchange")
    p.add_argument("--seed", type=int, default=1, metavar="N", help="seed for timestamps, UUIDs, counters (default 1)")
    p.add_argument("--no-expected", action="store_true", help="do not write <name>.expected.json")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="pcapng file to write")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import UsageError
    from ..rules import RULES
    from ..sim.fastpath import FAST_THRESHOLD, write_fast
    from ..sim.model import PROFILE_TELEGRAMS
    from ..sim.scenarios import INJECTIONS, NOT_INJECTABLE, write_capture
    from ..sim.config import Config, send_clock, station_clock

    if args.telegram not in PROFILE_TELEGRAMS[args.profile]:
        raise UsageError(f"--telegram {args.telegram} is not available with --profile {args.profile} "
                         f"(available: {', '.join(map(str, PROFILE_TELEGRAMS[args.profile]))})")
    if args.irt and args.cycle_ms == "1":
        args.cycle_ms = "0.25"
    try:
        cycle_list = [float(x) for x in args.cycle_ms.split(",")]
    except ValueError:
        raise UsageError(f"--cycle-time {args.cycle_ms}: one number or a comma list of numbers") from None
    if not 1 <= args.encoders <= 16:
        raise UsageError("--encoders must be 1..16")
    if len(cycle_list) > 1 and len(cycle_list) != args.encoders:
        raise UsageError(f"--cycle-time: {len(cycle_list)} cycle times for {args.encoders} encoder(s); "
                         "give one, or one per encoder")
    args.cycle_ms = cycle_list[0]
    try:
        for ms in cycle_list:
            send_clock(ms)
        for i in range(len(cycle_list)):
            station_clock(Config(cycle_ms=cycle_list[0], cycle_list=cycle_list), i)
    except ValueError as e:
        raise UsageError(f"--cycle-time: {e}") from None
    if not 0 <= args.io_devices <= 16:
        raise UsageError("--io-devices must be 0..16")
    if args.param_polls_ms and not 10 <= args.param_polls_ms <= 3_600_000:
        raise UsageError("--param-polls must be 0 (none) or within 10..3600000 ms")
    if not 0 <= args.it_fps <= 100_000:
        raise UsageError("--it-traffic must be within 0..100000 frames/s")
    if args.drift_ppm < 0 or args.drift_ppm > 1000 or args.jitter_us < 0:
        raise UsageError("--drift-ppm must be within 0..1000 and --jitter-us not negative")
    cycles = args.cycles if args.cycles is not None else \
        int(round(args.duration * 1000 / args.cycle_ms)) if args.duration is not None else 2000
    if cycles < 1:
        raise UsageError("--cycles/--duration must give at least one cycle")
    injects = []
    for spec in args.inject:
        rule, _, cyc = spec.partition("@")
        rule = rule.strip().upper()
        if rule not in RULES:
            raise UsageError(f"--inject {spec}: unknown rule ID (see pndiss/data/rules.json)")
        if rule not in INJECTIONS:
            raise UsageError(f"--inject {rule}: not injectable: {NOT_INJECTABLE.get(rule, 'see docs/simulate.md')}")
        try:
            c = int(cyc) if cyc else None
        except ValueError:
            raise UsageError(f"--inject {spec}: CYCLE must be an integer") from None
        if c is not None and not 1 <= c < cycles:
            raise UsageError(f"--inject {spec}: CYCLE must be within 1..{cycles - 1}")
        injects.append((rule, c))
    # faults that live in one scenario (a preset handshake, parking, a sensor error) pick it
    needs = {r: INJECTIONS[r].scenario for r, _ in injects if getattr(INJECTIONS[r], "scenario", None)}
    for r, sc in needs.items():
        if args.scenario is not None and sc != args.scenario:
            raise UsageError(f"--inject {r} needs --scenario {sc} (given: {args.scenario})")
        if len(set(needs.values())) > 1:
            raise UsageError("--inject: these faults need different scenarios: "
                             + ", ".join(f"{k} ({v})" for k, v in sorted(needs.items())))
    args.scenario = args.scenario or next(iter(needs.values()), "startup")
    if args.good_before_prmend and args.startup == "tidy":
        raise UsageError("--good-before-prmend needs --startup realistic")
    scaling = {}
    for item in filter(None, args.restart_scaling.split(",")):
        key, _, val = item.partition("=")
        key = key.strip().lower()
        if key not in ("mupr", "tmr", "direction", "velocity_unit"):
            raise UsageError(f"--restart-scaling {item}: KEY must be mupr, tmr, direction or velocity_unit")
        try:
            scaling[key] = int(val, 0)
        except ValueError:
            raise UsageError(f"--restart-scaling {item}: VALUE must be an integer") from None
    if scaling and args.restart is None:
        raise UsageError("--restart-scaling needs --restart CYCLE")
    if args.restart is not None and not 1 <= args.restart < cycles:
        raise UsageError(f"--restart must be within 1..{cycles - 1}")
    if args.restart_gap < 0:
        raise UsageError("--restart-gap must not be negative")
    if not 0 <= args.capture_loss <= 0.5:
        raise UsageError("--capture-loss must be within 0..0.5")
    mid = args.start_mid_session if args.start_mid_s is None else int(round(args.start_mid_s * 1000 / args.cycle_ms))
    if mid is not None and not 0 <= mid < cycles - 10:
        raise UsageError(f"--start-mid-session must leave at least 10 cycles: within 0..{cycles - 11}")
    cfg = Config(scenario=args.scenario, profile=args.profile, telegram=args.telegram, cycle_ms=args.cycle_ms,
                 cycles=cycles, encoders=args.encoders, injects=injects, seed=args.seed,
                 startup=args.startup, records=args.records, good_before_prmend=args.good_before_prmend,
                 restart=args.restart, restart_scaling=scaling, restart_gap_ms=args.restart_gap,
                 restart_mode=args.restart_mode,
                 capture_loss=args.capture_loss, start_mid_session=mid,
                 cycle_list=cycle_list if len(cycle_list) > 1 else None, drift_ppm=args.drift_ppm,
                 jitter_us=args.jitter_us, irt=args.irt, io_devices=args.io_devices,
                 param_polls_ms=args.param_polls_ms, it_fps=args.it_fps)
    try:
        if cycles >= FAST_THRESHOLD and not injects and args.scenario == "startup" and not cfg.good_before_prmend \
                and cfg.restart is None and cfg.start_mid_session is None \
                and cfg.cycle_list is None and not cfg.io_devices:
            truth = write_fast(cfg, args.output, expected=not args.no_expected)
        else:
            truth = write_capture(cfg, args.output, expected=not args.no_expected)
    except OSError as e:
        raise UsageError(f"cannot write {args.output}: {e.strerror}") from None
    except ValueError as e:
        raise UsageError(str(e)) from None
    print(f"pndiss simulate: wrote {truth['frames']} frames to {args.output}"
          + (f" ({len(truth['faults'])} injected fault(s))" if truth["faults"] else ""), file=sys.stderr)
    return 0
