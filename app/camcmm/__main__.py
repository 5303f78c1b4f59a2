from camcmm.cli.main import main

raise SystemExit(main())
