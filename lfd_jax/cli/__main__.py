from lfd_jax.cli._src.app import main

raise SystemExit(main())
