from beam.cli.main import main

raise SystemExit(main())
