from experiments.skin_real.stages import main

main()
