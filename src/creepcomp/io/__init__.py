"""Reading and writing files: measured records (CSV, ``records``) and model and design files
(JSON, ``jsonfiles``)."""

from creepcomp.io.records import (REQUIRED, OPTIONAL, COLUMNS, TIME_UNITS_TO_SECONDS, Record,
                                  check_arrays, parse_columns, read_record, parse_record,
                                  write_record)
from creepcomp.io.jsonfiles import (read_json, to_json, write_json, read_model, write_model, Design,
                                    read_design, write_design)

__all__ = ["REQUIRED", "OPTIONAL", "COLUMNS", "TIME_UNITS_TO_SECONDS", "Record", "check_arrays",
           "parse_columns", "read_record", "parse_record", "write_record", "read_json", "to_json",
           "write_json", "read_model", "write_model", "Design", "read_design", "write_design"]
