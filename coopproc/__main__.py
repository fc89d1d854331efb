from coopproc.cli import main

main()
