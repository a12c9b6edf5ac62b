"""What people read: the HTML kit, run / suite / sweep pages, and queries of the SQLite store."""
