"""``python -m tyre_farm_cli``: the ``farm`` command (``python -m farm`` is the same)."""

if __name__ == "__main__":  # guarded: Dask's spawned worker processes re-import this module
    from tyre_farm_cli import main

    main()
