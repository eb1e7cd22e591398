"""Reference solutions and the verification scenes built on them."""
