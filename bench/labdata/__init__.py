"""Lab data: measured records in, virtual campaigns out.

Owns the file formats of other tools (UFF dataset 58 ASCII and binary, CSV,
SDyPy SEP005 time-series dictionaries), the conversion of their units to SI,
the sensor map that fills in what a file lacks, and the import of such files
into a trace folder (``docs/trace-format.md``) and the export of a campaign's
traces back to them. May import ``structbench.harness.trace_writer`` and
``structbench.models.channels`` (to write traces the identifiers read
unchanged), ``structbench.identifier.io.traces`` (to read them) and
``structbench.models.errors``; never the evaluation, identification or CLI.
"""
