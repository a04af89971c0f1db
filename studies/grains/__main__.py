from studies.grains import main

main()
