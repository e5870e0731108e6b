"""The ``main`` of the analysis command lines: bad input ends with one line and exit status 2."""

import sys


def run(build_parser, prog, argv=None):
    args = build_parser().parse_args(argv)
    try:
        args.func(args)
    except (ValueError, FileNotFoundError, KeyError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    return 0
