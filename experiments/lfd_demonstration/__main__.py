from experiments.lfd_demonstration.stages import main

main()
