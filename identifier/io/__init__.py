"""The identifiers' files: trace files in (:mod:`.traces`, over the low-level
HDF5 reads of :mod:`.hdf5_reads`), result records and their JSON file out
(:mod:`.results`, checked by :mod:`.result_checks` over :mod:`.json_checks`).
Imports nothing of structbench but :mod:`structbench.models` errors."""
