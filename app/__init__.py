"""Web service of pneucore: FastAPI app, pydantic schemas, SQLite store, jobs."""
