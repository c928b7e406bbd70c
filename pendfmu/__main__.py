from pendfmu.cli import main

raise SystemExit(main())
