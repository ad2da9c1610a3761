from experiments.grasp_recognition.stages import main

main()
