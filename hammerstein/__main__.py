"""``python -m hammerstein``: the same as the ``hammerstein`` console script."""

from hammerstein.cli.main import run

if __name__ == "__main__":
    run()
