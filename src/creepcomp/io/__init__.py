"""Reading and writing files: measured records (CSV) and model and design files (JSON)."""
