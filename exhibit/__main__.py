from exhibit.cli import main

raise SystemExit(main())
