"""``python -m blendvoca.live``: send a blendshape track to an engine live, frame by frame at its rate.

::

    python -m blendvoca.live --coeffs FILE --to livelink://HOST:PORT [--fps F] [--loop]
    python -m blendvoca.live --method NAME [--checkpoint DIR] [--rig RIG] --audio WAV \\
        --to osc://HOST:PORT [--osc-style arkit|vmc] [--play-audio]
    python -m blendvoca.live --listen livelink://HOST:PORT --out take.csv [--frames N] [--seconds S]

``--to livelink://HOST:11111`` sends Live Link Face's UDP packets (Unreal's Live Link
Face source: add it in Window > Live Link with the subject name of ``--subject``);
``--to osc://HOST:PORT`` sends one OSC bundle per frame, a message per ARKit shape
(``--osc-style arkit``: address ``/ARKit/<name>``; ``vmc``: the VMC protocol of
VSeeFace and VirtualMotionCapture, port 39539). ``--coeffs`` is a BlendVOCA / SAiD CSV
(60 fps unless ``--fps``), a Live Link Face take (its rate and rotations) or a
``benchmark.generate`` ``.npy``; ``--method`` animates ``--audio`` first through
``benchmark.generate`` (a vertex method through the streaming solver on ``--rig``).
Frames leave at ``start + k / fps`` on the monotonic clock; ``--loop`` repeats the
track until Ctrl-C. ``--play-audio`` plays ``--audio`` from the first frame (needs
``sounddevice``). The last line says how many frames were sent and how late.
``--listen livelink://HOST:PORT --out take.csv [--frames N] [--seconds S]`` receives
instead: the Live Link packets that arrive (from this command or Epic's app) are
written as a Live Link Face take.

A mistake is one ``error:`` line and exit status 2, before the first frame: a malformed
``--to`` (scheme, host, port) or one that cannot be reached, a file that is missing or
malformed, a track with names the protocol has no place for (named), a method or WAV
``benchmark.generate`` refuses, a ``--listen`` port in use. See docs/streaming.md, "Live output".
"""

from __future__ import annotations

import sys

from blendvoca import cli
from blendvoca.errors import UserError
from blendvoca.live import livelink_udp, osc
from blendvoca.live.receiver import parse_listen, record_take
from blendvoca.live.sender import open_socket, parse_target, send_frames
from blendvoca.live.sources import track_from_file, track_from_method

#: The Live Link subject and device id sent unless told.
DEFAULT_SUBJECT = "BlendVOCA"
DEFAULT_DEVICE_ID = "blendvoca-live"


def build_parser():
    p = cli.parser("blendvoca.live", __doc__)
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--coeffs", metavar="FILE",
                      help="track to send: coefficient CSV (BlendVOCA/SAiD at 60 fps, or a Live Link Face take) "
                           "or benchmark.generate's .npy")
    what.add_argument("--method", metavar="NAME",
                      help="animate --audio with this method first (python -m benchmark.run --list)")
    what.add_argument("--listen", metavar="URL",
                      help="receive instead: record the Live Link packets arriving at livelink://HOST:PORT to --out")
    p.add_argument("--to", metavar="URL",
                   help="livelink://HOST:PORT (Unreal's Live Link Face source, port 11111) or osc://HOST:PORT")
    p.add_argument("--out", metavar="FILE", help="--listen: the Live Link Face take (.csv) to write")
    p.add_argument("--frames", type=int, metavar="N", help="--listen: stop after N frames (default: at Ctrl-C)")
    p.add_argument("--seconds", type=float, metavar="S", help="--listen: stop after S seconds")
    p.add_argument("--audio", metavar="WAV", help="speech: the input of --method, the sound of --play-audio")
    p.add_argument("--checkpoint", metavar="DIR", help="--method's trained folder (benchmark.run --checkpoint DIR)")
    p.add_argument("--style", metavar="S", help="--method's speaker (default: its first)")
    p.add_argument("--seed", type=int, default=0, metavar="K", help="--method's sampling seed (default 0)")
    p.add_argument("--rig", metavar="RIG",
                   help="a vertex method's rig (.npz or SAiD folder): its meshes are solved to these shapes by "
                        "the streaming solver")
    p.add_argument("--fps", type=float, metavar="F",
                   help="frames per second (default: 60 for BlendVOCA tracks, a Live Link take's own rate)")
    p.add_argument("--loop", action="store_true", help="repeat the track until Ctrl-C")
    p.add_argument("--play-audio", action="store_true", help="play --audio from the first frame (needs sounddevice)")
    p.add_argument("--subject", default=DEFAULT_SUBJECT,
                   help=f"Live Link subject name (default {DEFAULT_SUBJECT})")
    p.add_argument("--device-id", default=DEFAULT_DEVICE_ID, help=f"Live Link device id (default {DEFAULT_DEVICE_ID})")
    p.add_argument("--osc-style", choices=osc.STYLES, default="arkit",
                   help="OSC addresses: arkit (/ARKit/<name> f, default) or vmc (/VMC/Ext/Blend/Val s f, then Apply)")
    p.add_argument("--osc-prefix", default=osc.DEFAULT_PREFIX,
                   help=f"address prefix of --osc-style arkit (default {osc.DEFAULT_PREFIX})")
    p.add_argument("--osc-case", choices=osc.CASES, default="camel",
                   help="shape names on the wire: camel (jawOpen, default) or pascal (JawOpen)")
    cli.add_data_option(p)
    cli.add_config_options(p)
    cli.add_device_option(p, default="cpu")
    cli.add_quiet_option(p)
    return p


def _checked_args(args) -> None:
    """Refuse flag combinations that cannot run, before anything is read or generated."""
    if args.listen is not None:
        for flag, value in (("--to", args.to), ("--audio", args.audio), ("--loop", args.loop)):
            if value:
                raise UserError(f"{flag} belongs to sending; --listen records what arrives")
        if args.out is None:
            raise UserError("--listen needs --out FILE.csv, the Live Link Face take to write")
        if not str(args.out).lower().endswith(".csv"):
            raise UserError(f"--out {args.out}: expected a .csv (a Live Link Face take)")
        if args.frames is not None and args.frames < 1:
            raise UserError(f"--frames: expected an integer >= 1, got {args.frames}")
        if args.seconds is not None and not args.seconds > 0:
            raise UserError(f"--seconds: expected a positive number, got {args.seconds}")
        return
    for flag, value in (("--out", args.out), ("--frames", args.frames), ("--seconds", args.seconds)):
        if value is not None:
            raise UserError(f"{flag} belongs to --listen")
    if args.to is None:
        raise UserError("--to URL is needed: livelink://HOST:PORT or osc://HOST:PORT")
    if args.method is None:
        for flag, value in (("--checkpoint", args.checkpoint), ("--style", args.style), ("--rig", args.rig),
                            ("--config", args.config or None), ("--preset", args.preset)):
            if value:
                raise UserError(f"{flag} belongs to --method; --coeffs sends the file as it is")
    elif args.audio is None:
        raise UserError("--method needs --audio WAV, the speech to animate")
    if args.play_audio and args.audio is None:
        raise UserError("--play-audio needs --audio WAV, the sound to play")


@cli.command
def main(argv=None) -> int:
    """Command line entry point (see the module docstring)."""
    args = build_parser().parse_args(argv)
    _checked_args(args)
    if args.listen is not None:
        host, port = parse_listen(args.listen)
        written = record_take(host, port, args.out, frames=args.frames, seconds=args.seconds)
        print(f"recorded {written} frames from {args.listen} to {args.out}")
        return cli.EXIT_OK
    target = parse_target(args.to)
    carries = ("Live Link Face's packet (the 52 ARKit shapes and 9 rotations)" if target.scheme == "livelink"
               else "OSC output (ARKit shapes by name)")
    if target.scheme == "osc":
        prefix = osc.check_prefix(args.osc_prefix)
        osc._pythonosc()  # python-osc missing: the install line before a track is generated
    if args.coeffs is not None:
        track = track_from_file(args.coeffs, fps=args.fps, carries=carries)
    else:
        from benchmark.methods import method_schema  # see blendvoca.live.sources.track_from_method

        cli.require_address_space("blendvoca.live --method")
        config = cli.parse_config(args.config, preset=args.preset, schema=method_schema(args.method),
                                  method=args.method)
        track = track_from_method(args.method, args.audio, checkpoint=args.checkpoint, style=args.style,
                                  rig=args.rig, config=config, data=args.data,
                                  device=cli.checked_device(args.device), seed=args.seed, fps=args.fps)
    if len(track) == 0:
        raise UserError(f"{track.source}: no frames to send")
    if target.scheme == "livelink":
        values = livelink_udp.packet_values(track.values, track.names, track.pose)
        rate = livelink_udp.rate_fraction(track.fps)

        def datagram(k: int) -> bytes:
            return livelink_udp.encode_packet(values[k % len(values)], device_id=args.device_id,
                                              subject=args.subject, frame_number=k, rate=rate)
    else:
        names = osc.osc_names(track.names, args.osc_case)
        bundles = [osc.frame_bundle(row, names, style=args.osc_style, prefix=prefix) for row in track.values]

        def datagram(k: int) -> bytes:
            return bundles[k % len(bundles)]

    on_start = None
    if args.play_audio:
        from blendvoca.live.playback import playback_starter

        on_start = playback_starter(args.audio)
    sock = open_socket(target)
    with sock:
        report = send_frames(sock, datagram, None if args.loop else len(track), track.fps, target=target,
                             on_start=on_start, desc=f"to {target}")
    if report.refused:
        print(f"warning: {report.refused} frame(s) refused by {target.host}:{target.port} (nothing listening "
              "there yet?); each was sent again once", file=sys.stderr)
    print(f"{report.summary()} to {target}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
