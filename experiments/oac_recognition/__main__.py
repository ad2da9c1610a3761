from experiments.oac_recognition.stages import main

main()
