"""Lab data: measured records in, virtual campaigns out.

Owns the file formats of other tools (UFF dataset 58 ASCII and binary, CSV,
SDyPy SEP005 time-series dictionaries), the conversion of their units to SI,
the sensor map that fills in or overrides what a file says, and the import
of such files into a trace folder (``docs/trace-format.md``) and the export
of a campaign's traces back to them; also the test geometry (UFF 15/2411,
82, 2412, 18/2420 to ``geometry.json``, ``docs/geometry-format.md``, or from
a model's node coordinates), modal results as UFF 55 (in and out) and UFF 58
spectra as arrays for the FRF file. May import
``structbench.harness.trace_writer`` and ``structbench.models.channels`` (to
write traces the identifiers read unchanged),
``structbench.identifier.io.traces`` (to read them) and
``structbench.models.errors``; never the evaluation, identification, the FRF
and results writers (the API hands those over) or the CLI.
"""
