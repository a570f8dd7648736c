from fallgen.cli import main

main()
