from loomfmu.bench.cli import main

raise SystemExit(main())
