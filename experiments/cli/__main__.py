from experiments.cli.app import main

raise SystemExit(main())
