"""Build every loomfmu model into dist/<model>.fmu, validate and verify each,
write dist/report.json and print a summary table.

A thin wrapper around ``loomfmu build`` (same options: ``python build_fmu.py
--help``), kept because the README's first command runs it:

    python build_fmu.py [MODEL ...] [--out-dir dist] [--rtol 1e-6] [--max-error 1e-3]
                        [--fmi-version 2|3] [--interface cs|me|both]
                        [--platforms linux64,win64,aarch64]

The default is FMI 2.0 co-simulation into dist/<model>.fmu; other variants
go to dist/<model>_fmi<version>_<interface>.fmu (same report.json, keyed by
the FMU's name). Each FMU carries a binary for every platform whose compiler
is installed (x86-64 Linux with gcc; x86-64 Windows with mingw-w64; aarch64
Linux with aarch64-linux-gnu-gcc, FMI 3.0 only), unless --platforms or
$LOOMFMU_PLATFORMS names them; one line names the platforms skipped.

Exits 1 if an FMU has a validation problem or if any solver's worst output
misses the reference by more than --max-error (relative to the output's
range), 2 on a usage error.
"""
import sys

from loomfmu.cli.dispatch import main

if __name__ == "__main__":
    sys.exit(main(["build", *sys.argv[1:]]))
