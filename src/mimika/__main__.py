from mimika.cli import main

raise SystemExit(main())
