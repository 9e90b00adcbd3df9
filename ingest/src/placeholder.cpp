// placeholder until the ingest module lands
