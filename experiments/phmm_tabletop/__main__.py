from experiments.phmm_tabletop.stages import main

main()
